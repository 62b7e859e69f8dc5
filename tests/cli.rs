//! Integration tests of the `analytic-fog` binary (feature `cli`): the happy path against
//! the library's scalar path bit for bit, and every class of bad input (exit status 2, one
//! line on stderr naming file, line and field, no output file left behind).

use analytic_fog::{simd_level, Scene, SceneDesc};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_analytic-fog");
const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/data");
const OUT_HEADER: &str = "tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b";

/// A fresh, empty directory for one test.
fn workdir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run analytic-fog")
}

fn eval(dir: &Path, scene: &str, rays: &str, out: &str, extra: &[&str]) -> Output {
    let mut args = vec!["eval", "--scene", scene, "--rays", rays, "--out", out];
    args.extend_from_slice(extra);
    run(dir, &args)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn parse_rays(text: &str) -> Vec<[f32; 7]> {
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("ox,oy,oz,dx,dy,dz,t"));
    lines
        .map(|l| {
            let v: Vec<f32> = l.split(',').map(|f| f.parse().unwrap()).collect();
            v.try_into().unwrap()
        })
        .collect()
}

/// Runs `eval` on a shipped scene and the shipped rays and checks every output value, as
/// printed and read back, bit for bit against `Scene::eval_ray` (the scalar path).
fn check_against_library(scene_file: &str, extra: &[&str]) -> String {
    let dir = workdir(&format!("happy-{scene_file}-{}", extra.len()));
    let scene_path = format!("{DATA}/{scene_file}");
    let rays_path = format!("{DATA}/rays.csv");
    let o = eval(&dir, &scene_path, &rays_path, "fog.csv", extra);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let rays = parse_rays(&std::fs::read_to_string(&rays_path).unwrap());
    if !extra.contains(&"--quiet") {
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(simd_level()), "{err}");
        assert!(err.contains(&format!("{} rays", rays.len())), "{err}");
    }
    assert_eq!(files_in(&dir), ["fog.csv"]);

    let desc: SceneDesc =
        serde_json::from_str(&std::fs::read_to_string(&scene_path).unwrap()).unwrap();
    let scene = Scene::new(desc).unwrap();
    let out = std::fs::read_to_string(dir.join("fog.csv")).unwrap();
    let mut lines = out.lines();
    assert_eq!(lines.next(), Some(OUT_HEADER));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), rays.len());
    let (mut n_inf, mut n_zero_t) = (0, 0);
    for (i, (row, r)) in rows.iter().zip(&rays).enumerate() {
        let got: Vec<f32> = row
            .split(',')
            .map(|f| f.parse().unwrap_or_else(|_| panic!("row {i}: {f:?}")))
            .collect();
        assert_eq!(got.len(), 9, "row {i}: {row}");
        let s = scene.eval_ray(
            Vec3::new(r[0], r[1], r[2]),
            Vec3::new(r[3], r[4], r[5]),
            r[6],
        );
        let want = [s.tau, s.transmittance, s.inscattering]
            .iter()
            .flat_map(|v| v.to_array())
            .collect::<Vec<f32>>();
        for k in 0..9 {
            assert_eq!(
                got[k].to_bits(),
                want[k].to_bits(),
                "ray {i} (line {}), column {k}: got {}, library {}",
                i + 2,
                got[k],
                want[k]
            );
            assert!(!got[k].is_nan(), "ray {i}");
        }
        n_inf += usize::from(got[0] == f32::INFINITY);
        n_zero_t += usize::from(got[3] == 0.0);
    }
    // The shipped rays include rays to infinity with an infinite optical depth.
    assert!(n_inf > 0 && n_zero_t >= n_inf);
    out
}

#[test]
fn eval_matches_library_bit_for_bit() {
    let a = check_against_library("valley.json", &[]);
    // Chunked streaming (7 rays per chunk) writes the same bytes.
    let b = check_against_library("valley.json", &["--chunk-rays", "7", "--quiet"]);
    assert_eq!(a, b);
    check_against_library("haze.json", &[]);
    // Height fog with fog volumes and a cut-out (39 of the 313 rays cross a volume).
    let v = check_against_library("banks.json", &[]);
    assert_ne!(v, a, "the volumes change the output");
}

#[test]
fn info_and_version() {
    let dir = workdir("info");
    for args in [&["info"][..], &["--version"][..]] {
        let o = run(&dir, args);
        assert!(o.status.success());
        let s = String::from_utf8_lossy(&o.stdout);
        assert!(s.contains(env!("CARGO_PKG_VERSION")), "{s}");
        assert!(s.contains(simd_level()), "{s}");
        // The run-time AVX-512 dispatch is named where it happens, and only there.
        let dispatch = analytic_fog::avx512_dispatch();
        assert_eq!(s.contains("avx512 at run time"), dispatch, "{s}");
    }
}

#[test]
fn rays_csv_variants_accepted() {
    let dir = workdir("variants");
    std::fs::write(
        dir.join("r.csv"),
        "\u{feff}ox,oy,oz,dx,dy,dz,t\r\n0,2,0,0,1,0,inf\r\n 0 , 2 ,0,0,1,0, +inf\r\n\
         0,2,0,0,1,0,Infinity\r\n0,2,0,0,-1,0,1e+1\r\n\r\n\n",
    )
    .unwrap();
    std::fs::copy(format!("{DATA}/valley.json"), dir.join("s.json")).unwrap();
    let o = eval(&dir, "s.json", "r.csv", "o.csv", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = std::fs::read_to_string(dir.join("o.csv")).unwrap();
    let rows: Vec<&str> = out.lines().skip(1).collect();
    assert_eq!(rows.len(), 4);
    assert_eq!(rows[0], rows[1]);
    assert_eq!(rows[0], rows[2]);

    // A scene written with every optional field left out, RGB as one number.
    std::fs::write(
        dir.join("min.json"),
        r#"{"height_fog": [{"base_height": 1, "falloff": 0, "components": [{"scattering": 0.5}]}]}"#,
    )
    .unwrap();
    let o = eval(&dir, "min.json", "r.csv", "o.csv", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = std::fs::read_to_string(dir.join("o.csv")).unwrap();
    // Homogeneous fog, no light: tau = 0.5 * 10, T = exp(-5), no in-scattering.
    let row: Vec<f32> = out
        .lines()
        .nth(4)
        .unwrap()
        .split(',')
        .map(|f| f.parse().unwrap())
        .collect();
    for c in 0..3 {
        assert!((row[c] - 5.0).abs() <= 5.0 * 4.0 * f32::EPSILON, "{row:?}");
        assert!(
            (row[3 + c] - (-5.0f32).exp()).abs() <= 1e-6 * (-5.0f32).exp(),
            "{row:?}"
        );
        assert_eq!(row[6 + c], 0.0);
    }

    // An empty rays file (header only) gives a header-only output.
    std::fs::write(dir.join("e.csv"), "ox,oy,oz,dx,dy,dz,t\n").unwrap();
    let o = eval(&dir, "s.json", "e.csv", "o.csv", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(dir.join("o.csv")).unwrap(),
        format!("{OUT_HEADER}\n")
    );
}

const GOOD_SCENE: &str = r#"{ "up": [0, 1, 0],
  "height_fog": [ { "base_height": 0.0, "falloff": 0.08,
      "components": [ { "scattering": [0.02, 0.02, 0.02], "absorption": [0, 0, 0],
                        "phase": {"henyey_greenstein": 0.7} } ] } ],
  "lighting": { "ambient": [0.5, 0.6, 0.7],
                "sun": { "direction": [0.3, 0.4, -0.87], "radiance": [20, 18, 15] } } }
"#;
const GOOD_RAYS: &str = "ox,oy,oz,dx,dy,dz,t\n0,2,0,0,0.1,1,100\n0,2,0,0,-0.1,1,inf\n";

/// Runs `eval` on the given scene and rays text and checks the error contract: exit
/// status 2, exactly one line on stderr starting `error: ` and containing every part of
/// `want`, and nothing but the inputs left in the directory.
fn expect_error(
    name: &str,
    scene: Option<&str>,
    rays: Option<&str>,
    extra: &[&str],
    want: &[&str],
) {
    let dir = workdir(&format!("err-{name}"));
    let mut inputs = Vec::new();
    if let Some(s) = scene {
        std::fs::write(dir.join("scene.json"), s).unwrap();
        inputs.push("scene.json".to_string());
    }
    if let Some(r) = rays {
        // U+FFFD stands for a byte that is not UTF-8.
        let bytes: Vec<u8> = r
            .split('\u{fffd}')
            .collect::<Vec<_>>()
            .join("\u{1}")
            .bytes()
            .map(|b| if b == 1 { 0xff } else { b })
            .collect();
        std::fs::write(dir.join("rays.csv"), bytes).unwrap();
        inputs.push("rays.csv".to_string());
    }
    inputs.sort();
    let o = eval(&dir, "scene.json", "rays.csv", "out.csv", extra);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{name}: {err}");
    assert!(o.stdout.is_empty(), "{name}");
    assert!(err.starts_with("error: "), "{name}: {err}");
    assert!(
        err.ends_with('\n') && err.lines().count() == 1,
        "{name}: not one line: {err:?}"
    );
    for w in want {
        assert!(err.contains(w), "{name}: {err:?} lacks {w:?}");
    }
    assert_eq!(files_in(&dir), inputs, "{name}: output left behind");
}

#[test]
fn unreadable_files() {
    expect_error(
        "no-scene",
        None,
        Some(GOOD_RAYS),
        &[],
        &["scene.json: cannot read"],
    );
    expect_error(
        "no-rays",
        Some(GOOD_SCENE),
        None,
        &[],
        &["rays.csv: cannot read"],
    );
    // The output directory does not exist.
    let dir = workdir("no-out-dir");
    std::fs::write(dir.join("scene.json"), GOOD_SCENE).unwrap();
    std::fs::write(dir.join("rays.csv"), GOOD_RAYS).unwrap();
    let o = eval(&dir, "scene.json", "rays.csv", "missing/out.csv", &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.starts_with("error: missing/out.csv: cannot create"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(files_in(&dir), ["rays.csv", "scene.json"]);
}

#[test]
fn malformed_json() {
    let cases: &[(&str, &str, &[&str])] = &[
        ("syntax", "{\"up\": [0, 1, 0],\n \"height_fog\": [,] }", &["scene.json:2:", "field height_fog"]),
        ("empty", "", &["scene.json:1:", "EOF"]),
        ("trailing", "{} x", &["scene.json:1:4:", "trailing characters"]),
        (
            "type",
            "{\"height_fog\": [ {\"base_height\": 0,\n \"falloff\": \"x\", \"components\": [{\"scattering\": 1}]} ]}",
            &["scene.json:2:", "field height_fog[0].falloff", "invalid type"],
        ),
        (
            "unknown",
            "{\"height_fog\": [],\n \"fog\": 1}",
            &["scene.json:2:", "field fog", "unknown field `fog`"],
        ),
        (
            "missing",
            "{\"height_fog\": [ {\"base_height\": 0,\n \"components\": [{\"scattering\": 1}]} ]}",
            &["scene.json:2:", "field height_fog[0]", "missing field `falloff`"],
        ),
        (
            "rgb-length",
            "{\"height_fog\": [ {\"base_height\": 0, \"falloff\": 1,\n \"components\": [{\"scattering\": [1, 2]}]} ]}",
            &["scene.json:2:", "field height_fog[0].components[0].scattering", "invalid length 2"],
        ),
        (
            "phase",
            "{\"height_fog\": [ {\"base_height\": 0, \"falloff\": 1,\n \"components\": [{\"scattering\": 1, \"phase\": \"mie\"}]} ]}",
            &["scene.json:2:", "field height_fog[0].components[0].phase", "unknown variant `mie`"],
        ),
    ];
    for (name, scene, want) in cases {
        expect_error(
            &format!("json-{name}"),
            Some(scene),
            Some(GOOD_RAYS),
            &[],
            want,
        );
    }
}

#[test]
fn invalid_scene_values() {
    let layer = |falloff: &str, comp: &str| {
        format!(
            "{{\"height_fog\": [ {{\"base_height\": 0,\n \"falloff\": {falloff},\n \"components\": [\n {comp} ]}} ]}}"
        )
    };
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "negative",
            layer("1", "{\"scattering\": [0.1, -0.2, 0.1]}"),
            vec![
                "scene.json:4:",
                "field height_fog[0].components[0].scattering[1]",
                ">= 0",
            ],
        ),
        (
            "negative-absorption",
            layer("1", "{\"scattering\": 1, \"absorption\": -1}"),
            vec![
                "scene.json:4:",
                "field height_fog[0].components[0].absorption[0]",
                ">= 0",
            ],
        ),
        (
            "non-finite-coefficient",
            layer("1", "{\"scattering\": 1e39}"),
            vec![
                "scene.json:4:",
                "field height_fog[0].components[0].scattering[0]",
                "finite",
            ],
        ),
        (
            "non-finite-falloff",
            layer("-1e40", "{\"scattering\": 1}"),
            vec!["scene.json:2:", "field height_fog[0].falloff", "finite"],
        ),
        (
            "no-components",
            layer("1", ""),
            vec!["scene.json:3:", "field height_fog[0].components", "empty"],
        ),
        (
            "hg-range",
            layer(
                "1",
                "{\"scattering\": 1, \"phase\": {\"henyey_greenstein\": 1.5}}",
            ),
            vec![
                "scene.json:4:",
                "field height_fog[0].components[0].phase.henyey_greenstein",
            ],
        ),
        (
            "zero-up",
            "{\"height_fog\": [],\n \"up\": [0, 0, 0]}".to_string(),
            vec!["scene.json:2:", "field up", "non-zero"],
        ),
        (
            "zero-sun",
            "{\"lighting\": {\n \"sun\": {\"direction\": 0, \"radiance\": 1}}}".to_string(),
            vec!["scene.json:2:", "field lighting.sun.direction", "non-zero"],
        ),
        (
            "negative-ambient",
            "{\"lighting\": {\n \"ambient\": [1, 1, -1]}}".to_string(),
            vec!["scene.json:2:", "field lighting.ambient[2]", ">= 0"],
        ),
    ];
    for (name, scene, want) in &cases {
        expect_error(
            &format!("scene-{name}"),
            Some(scene),
            Some(GOOD_RAYS),
            &[],
            want,
        );
    }
}

#[test]
fn bad_rays() {
    let h = "ox,oy,oz,dx,dy,dz,t\n";
    let ok = "0,2,0,0,0.1,1,100\n";
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "empty",
            String::new(),
            vec!["rays.csv:1:", "field header", "empty"],
        ),
        (
            "header-order",
            format!("ox,oy,oz,dz,dy,dx,t\n{ok}"),
            vec!["rays.csv:1:", "field dx", "wrong header"],
        ),
        (
            "header-short",
            format!("ox,oy,oz,dx,dy,dz\n{ok}"),
            vec!["rays.csv:1:", "field t", "wrong header"],
        ),
        (
            "header-long",
            format!("ox,oy,oz,dx,dy,dz,t,w\n{ok}"),
            vec!["rays.csv:1:", "field #8", "wrong header"],
        ),
        (
            "short-row",
            format!("{h}{ok}0,2,0,0,0.1\n"),
            vec!["rays.csv:3:", "field dz", "missing"],
        ),
        (
            "long-row",
            format!("{h}{ok}{ok}0,2,0,0,0.1,1,100,7\n"),
            vec!["rays.csv:4:", "field #8", "unexpected"],
        ),
        (
            "not-a-number",
            format!("{h}{ok}0,2,0,0,abc,1,100\n"),
            vec!["rays.csv:3: field dy: not a number: \"abc\""],
        ),
        (
            "empty-field",
            format!("{h}0,,0,0,1,1,100\n"),
            vec!["rays.csv:2: field oy: not a number"],
        ),
        (
            "nan-origin",
            format!("{h}{ok}0,NaN,0,0,1,1,100\n"),
            vec!["rays.csv:3: field oy: must be finite"],
        ),
        (
            "inf-direction",
            format!("{h}0,2,0,inf,1,1,100\n"),
            vec!["rays.csv:2: field dx: must be finite"],
        ),
        (
            "overflowing-origin",
            format!("{h}0,2,1e39,0,1,1,100\n"),
            vec!["rays.csv:2: field oz: must be finite"],
        ),
        (
            "negative-t",
            format!("{h}{ok}{ok}{ok}0,2,0,0,1,1,-1\n"),
            vec!["rays.csv:5: field t: must be >= 0"],
        ),
        (
            "nan-t",
            format!("{h}0,2,0,0,1,1,nan\n"),
            vec!["rays.csv:2: field t: must be >= 0"],
        ),
        (
            "minus-inf-t",
            format!("{h}0,2,0,0,1,1,-inf\n"),
            vec!["rays.csv:2: field t: must be >= 0"],
        ),
        (
            "blank-line-inside",
            format!("{h}{ok}\n{ok}"),
            vec!["rays.csv:3:", "empty row"],
        ),
        (
            "not-utf8",
            format!("{h}0,2,0,0,\u{fffd},1,1\n"),
            vec!["rays.csv:2: field dy: not a number"],
        ),
    ];
    for (name, rays, want) in &cases {
        expect_error(
            &format!("rays-{name}"),
            Some(GOOD_SCENE),
            Some(rays),
            &[],
            want,
        );
    }
}

/// An error in a late chunk, after earlier chunks were written to the temporary file:
/// the temporary file is removed and no output appears. The first bad line is reported
/// even when several chunks of rows are parsed in parallel.
#[test]
fn late_error_leaves_no_output() {
    let mut rays = String::from("ox,oy,oz,dx,dy,dz,t\n");
    for i in 0..50_000 {
        if i == 40_000 || i == 45_000 {
            rays.push_str("0,2,0,0,1,x,1\n");
        } else {
            rays.push_str("0,2,0,0,-0.5,1,inf\n");
        }
    }
    for chunk in ["1000", "1048576"] {
        expect_error(
            &format!("late-{chunk}"),
            Some(GOOD_SCENE),
            Some(&rays),
            &["--chunk-rays", chunk],
            &["rays.csv:40002: field dz: not a number: \"x\""],
        );
    }
}

// ---------------------------------------------------------------------------------------
// NumPy .npy exchange. The test writes and reads .npy files with its own minimal code
// (below), independent of the binary's parser.

/// A .npy file: the magic, version `major`.0, the header `dict` (padded with spaces to a
/// multiple of 64 and ended with `\n`, as numpy writes it), then `data`.
fn npy_bytes(major: u8, dict: &str, data: &[u8]) -> Vec<u8> {
    let prelude = if major == 1 { 10 } else { 12 };
    let mut header = dict.as_bytes().to_vec();
    while !(prelude + header.len() + 1).is_multiple_of(64) {
        header.push(b' ');
    }
    header.push(b'\n');
    let mut v = b"\x93NUMPY".to_vec();
    v.extend_from_slice(&[major, 0]);
    if major == 1 {
        v.extend_from_slice(&u16::try_from(header.len()).unwrap().to_le_bytes());
    } else {
        v.extend_from_slice(&u32::try_from(header.len()).unwrap().to_le_bytes());
    }
    v.extend_from_slice(&header);
    v.extend_from_slice(data);
    v
}

fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// The standard header numpy writes for an N×C float32 array.
fn npy_dict(rows: usize, cols: usize) -> String {
    format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({rows}, {cols}), }}")
}

/// A rays .npy (version 1.0) holding `rays`.
fn rays_npy(rays: &[[f32; 7]]) -> Vec<u8> {
    npy_bytes(
        1,
        &npy_dict(rays.len(), 7),
        &f32_bytes(rays.iter().flatten().copied()),
    )
}

/// Reads an N×9 float32 output .npy: checks the magic, version 1.0, the header's layout
/// (a multiple of 64 bytes, ended with `\n`) and its fields; returns the rows.
fn read_out_npy(bytes: &[u8]) -> Vec<[f32; 9]> {
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
    let hlen = usize::from(u16::from_le_bytes([bytes[8], bytes[9]]));
    let start = 10 + hlen;
    assert_eq!(start % 64, 0, "header length {hlen}");
    let header = std::str::from_utf8(&bytes[10..start]).unwrap();
    assert!(header.ends_with('\n'), "{header:?}");
    assert!(header.contains("'descr': '<f4'"), "{header:?}");
    assert!(header.contains("'fortran_order': False"), "{header:?}");
    let shape = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .unwrap_or_else(|| panic!("no shape in {header:?}"));
    let dims: Vec<usize> = shape
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect();
    assert_eq!(dims.len(), 2, "{header:?}");
    assert_eq!(dims[1], 9, "{header:?}");
    let data = &bytes[start..];
    assert_eq!(data.len(), dims[0] * 36, "{header:?}: data length");
    data.chunks_exact(36)
        .map(|row| {
            let mut v = [0.0f32; 9];
            for (k, x) in v.iter_mut().enumerate() {
                *x = f32::from_le_bytes(row[4 * k..4 * k + 4].try_into().unwrap());
            }
            v
        })
        .collect()
}

/// The rows of an output CSV, each value read back as f32.
fn read_out_csv(text: &str) -> Vec<[f32; 9]> {
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(OUT_HEADER));
    lines
        .map(|l| {
            let v: Vec<f32> = l.split(',').map(|f| f.parse().unwrap()).collect();
            v.try_into().unwrap()
        })
        .collect()
}

fn bits(rows: &[[f32; 9]]) -> Vec<[u32; 9]> {
    rows.iter().map(|r| r.map(f32::to_bits)).collect()
}

/// csv→csv, csv→npy, npy→npy and npy→csv on the shipped rays give the same values bit
/// for bit, for several chunk sizes; the .npy output's header (its row count patched in
/// at the end for CSV input) reads back with the test's own parser.
#[test]
fn npy_round_trips() {
    let dir = workdir("npy-round-trips");
    let scene = format!("{DATA}/valley.json");
    let rays_csv = format!("{DATA}/rays.csv");
    let rays = parse_rays(&std::fs::read_to_string(&rays_csv).unwrap());
    std::fs::write(dir.join("rays.npy"), rays_npy(&rays)).unwrap();

    let o = eval(&dir, &scene, &rays_csv, "cc.csv", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let want_csv = std::fs::read_to_string(dir.join("cc.csv")).unwrap();
    let want = bits(&read_out_csv(&want_csv));
    assert_eq!(want.len(), rays.len());

    for chunk in ["1048576", "7", "313", "1"] {
        let extra = ["--chunk-rays", chunk, "--quiet"];
        for (rays_file, out) in [
            (rays_csv.as_str(), "cn.npy"),
            ("rays.npy", "nn.npy"),
            ("rays.npy", "nc.csv"),
            ("rays.npy", "NN.NPY"),
        ] {
            let o = eval(&dir, &scene, rays_file, out, &extra);
            assert!(o.status.success(), "{rays_file} -> {out}: {}", stderr(&o));
            assert!(o.stderr.is_empty(), "{}", stderr(&o));
            let bytes = std::fs::read(dir.join(out)).unwrap();
            if out.ends_with(".csv") {
                // The same text as csv -> csv.
                assert_eq!(String::from_utf8(bytes).unwrap(), want_csv, "{out}");
            } else {
                assert_eq!(bits(&read_out_npy(&bytes)), want, "{rays_file} -> {out}");
            }
        }
        // Whatever the input and chunk size, the same .npy bytes.
        let a = std::fs::read(dir.join("cn.npy")).unwrap();
        assert_eq!(a, std::fs::read(dir.join("nn.npy")).unwrap());
        assert_eq!(a, std::fs::read(dir.join("NN.NPY")).unwrap());
    }

    // The summary line names the ray count, as for CSV.
    let o = eval(&dir, &scene, "rays.npy", "nn.npy", &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(&format!("{} rays", rays.len())), "{err}");
    // --progress reports after every chunk (here not a terminal: one line each).
    let o = eval(
        &dir,
        &scene,
        "rays.npy",
        "nn.npy",
        &["--progress", "--chunk-rays", "100", "-q"],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(err.lines().count(), 4, "{err}");
    assert!(err.contains("313 / 313 rays (100.0%)"), "{err}");

    let mut files = files_in(&dir);
    files.retain(|f| f.starts_with('.'));
    assert!(files.is_empty(), "temporary files left: {files:?}");
}

/// Header variants numpy (or other writers) produce: versions 2.0 and 3.0, other key
/// order and quotes, no padding, `5L`, `'=f4'`, an empty array.
#[test]
fn npy_header_variants() {
    let dir = workdir("npy-variants");
    std::fs::write(dir.join("s.json"), GOOD_SCENE).unwrap();
    let rays: Vec<[f32; 7]> = (0..5)
        .map(|i| {
            [
                0.0,
                2.0,
                i as f32,
                0.0,
                0.1 * i as f32 - 0.2,
                1.0,
                10.0 + i as f32,
            ]
        })
        .collect();
    let data = f32_bytes(rays.iter().flatten().copied());
    std::fs::write(dir.join("r.npy"), rays_npy(&rays)).unwrap();
    let o = eval(&dir, "s.json", "r.npy", "want.npy", &["-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let want = std::fs::read(dir.join("want.npy")).unwrap();
    assert_eq!(read_out_npy(&want).len(), 5);

    let variants: Vec<(&str, Vec<u8>)> = vec![
        ("v2", npy_bytes(2, &npy_dict(5, 7), &data)),
        ("v3", npy_bytes(3, &npy_dict(5, 7), &data)),
        (
            "order-quotes",
            npy_bytes(
                1,
                "{\"shape\":(5,7),\"fortran_order\":False,\"descr\":\"<f4\"}",
                &data,
            ),
        ),
        (
            "long-int-native",
            npy_bytes(
                1,
                "{'descr': '=f4', 'fortran_order': False, 'shape': (5L, 7L)}",
                &data,
            ),
        ),
        ("unpadded", {
            let dict = npy_dict(5, 7);
            let mut v = b"\x93NUMPY\x01\x00".to_vec();
            v.extend_from_slice(&(dict.len() as u16).to_le_bytes());
            v.extend_from_slice(dict.as_bytes());
            v.extend_from_slice(&data);
            v
        }),
    ];
    for (name, bytes) in variants {
        let file = format!("{name}.npy");
        std::fs::write(dir.join(&file), bytes).unwrap();
        let o = eval(&dir, "s.json", &file, "o.npy", &["-q"]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert_eq!(std::fs::read(dir.join("o.npy")).unwrap(), want, "{name}");
    }

    // No rays: an empty array in, (0, 9) out; and from a header-only CSV.
    std::fs::write(dir.join("e.npy"), npy_bytes(1, &npy_dict(0, 7), &[])).unwrap();
    std::fs::write(dir.join("e.csv"), "ox,oy,oz,dx,dy,dz,t\n").unwrap();
    for input in ["e.npy", "e.csv"] {
        let o = eval(&dir, "s.json", input, "o.npy", &["-q"]);
        assert!(o.status.success(), "{input}: {}", stderr(&o));
        assert!(read_out_npy(&std::fs::read(dir.join("o.npy")).unwrap()).is_empty());
    }
    let o = eval(&dir, "s.json", "e.npy", "o.csv", &["-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(dir.join("o.csv")).unwrap(),
        format!("{OUT_HEADER}\n")
    );
}

/// Runs `eval` on a rays.npy holding `bytes` and checks the error contract (as
/// [`expect_error`]), for both a CSV and a .npy output.
fn expect_npy_error(name: &str, bytes: &[u8], extra: &[&str], want: &[&str]) {
    for out in ["out.csv", "out.npy"] {
        let dir = workdir(&format!("npy-err-{name}-{out}"));
        std::fs::write(dir.join("scene.json"), GOOD_SCENE).unwrap();
        std::fs::write(dir.join("rays.npy"), bytes).unwrap();
        let o = eval(&dir, "scene.json", "rays.npy", out, extra);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(o.stdout.is_empty(), "{name}");
        assert!(
            err.starts_with("error: rays.npy: "),
            "{name}: does not name the file: {err}"
        );
        assert!(
            err.ends_with('\n') && err.lines().count() == 1,
            "{name}: not one line: {err:?}"
        );
        for w in want {
            assert!(err.contains(w), "{name}: {err:?} lacks {w:?}");
        }
        assert_eq!(
            files_in(&dir),
            ["rays.npy", "scene.json"],
            "{name}: output left behind"
        );
    }
}

#[test]
fn bad_npy() {
    let ray = [0.0f32, 2.0, 0.0, 0.0, 0.1, 1.0, 100.0];
    let good = f32_bytes([ray; 5].into_iter().flatten());
    let with = |row: usize, col: usize, x: f32| {
        let mut rays = [ray; 5];
        rays[row][col] = x;
        rays_npy(&rays)
    };
    let dict = |descr: &str, fortran: &str, shape: &str| {
        format!("{{'descr': {descr}, 'fortran_order': {fortran}, 'shape': {shape}, }}")
    };
    let header_only = npy_bytes(1, &npy_dict(5, 7), &[]);
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "f8",
            npy_bytes(1, &dict("'<f8'", "False", "(5, 7)"), &[0; 280]),
            vec!["field descr", "'<f8'", "float64", "not supported", "'<f4'"],
        ),
        (
            "big-endian",
            npy_bytes(1, &dict("'>f4'", "False", "(5, 7)"), &good),
            vec!["field descr", "'>f4'", "big-endian float32"],
        ),
        (
            "int",
            npy_bytes(1, &dict("'<i4'", "False", "(5, 7)"), &good),
            vec!["field descr", "'<i4'", "int32"],
        ),
        (
            "structured",
            npy_bytes(1, &dict("[('ox', '<f4')]", "False", "(35,)"), &good),
            vec!["field descr", "structured dtype"],
        ),
        (
            "fortran",
            npy_bytes(1, &dict("'<f4'", "True", "(5, 7)"), &good),
            vec!["field fortran_order", "True", "C order"],
        ),
        (
            "one-dimension",
            npy_bytes(1, &dict("'<f4'", "False", "(35,)"), &good),
            vec!["field shape", "(35,)", "1 dimension", "(N, 7)"],
        ),
        (
            "three-dimensions",
            npy_bytes(1, &dict("'<f4'", "False", "(5, 7, 1)"), &good),
            vec!["field shape", "(5, 7, 1)", "3 dimensions"],
        ),
        (
            "columns",
            npy_bytes(1, &dict("'<f4'", "False", "(7, 5)"), &good),
            vec!["field shape", "(7, 5)", "5 columns", "ox,oy,oz,dx,dy,dz,t"],
        ),
        (
            "truncated-mid-row",
            good_npy_cut(&rays_npy(&[ray; 5]), 30),
            vec![
                "truncated data",
                "promises 5 rows",
                "ends at row 3",
                "110 of 140 bytes",
            ],
        ),
        (
            "truncated-at-row",
            good_npy_cut(&rays_npy(&[ray; 5]), 56),
            vec![
                "truncated data",
                "promises 5 rows",
                "ends at row 3 (3 complete rows",
            ],
        ),
        (
            "no-data",
            header_only,
            vec!["truncated data", "promises 5 rows", "ends at row 0"],
        ),
        (
            "extra-bytes",
            npy_bytes(1, &npy_dict(5, 7), &[good.as_slice(), &[0; 3]].concat()),
            vec!["3 bytes of extra data after the 5 rows"],
        ),
        (
            "bad-magic",
            b"ox,oy,oz,dx,dy,dz,t\n0,2,0,0,1,0,1\n".to_vec(),
            vec!["not a .npy file", "bad magic"],
        ),
        ("empty", Vec::new(), vec!["not a .npy file", "empty"]),
        (
            "short",
            b"\x93NUM".to_vec(),
            vec!["not a .npy file", "ends after 4 bytes"],
        ),
        (
            "version",
            {
                let mut v = rays_npy(&[ray; 5]);
                v[6] = 4;
                v
            },
            vec!["unsupported .npy format version 4.0"],
        ),
        (
            "header-syntax",
            npy_bytes(
                1,
                "{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7}",
                &good,
            ),
            vec!["bad header", "expected ',' or ')'", "'shape': (5, 7}"],
        ),
        (
            "header-missing-key",
            npy_bytes(1, "{'descr': '<f4', 'shape': (5, 7)}", &good),
            vec!["bad header", "'fortran_order' missing"],
        ),
        (
            "header-unknown-key",
            npy_bytes(
                1,
                "{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7), 'x': 1}",
                &good,
            ),
            vec!["bad header", "unexpected key 'x'"],
        ),
        (
            "header-not-dict",
            npy_bytes(1, "(5, 7)", &good),
            vec!["bad header", "expected a dict"],
        ),
        (
            "header-length",
            {
                let mut v = b"\x93NUMPY\x01\x00".to_vec();
                v.extend_from_slice(&1000u16.to_le_bytes());
                v.extend_from_slice(npy_dict(5, 7).as_bytes());
                v
            },
            vec!["truncated header", "1000 bytes promised"],
        ),
        (
            "nan-origin",
            with(2, 1, f32::NAN),
            vec!["rays.npy: row 2: field oy: must be finite, got NaN"],
        ),
        (
            "inf-direction",
            with(4, 3, f32::INFINITY),
            vec!["rays.npy: row 4: field dx: must be finite, got inf"],
        ),
        (
            "negative-t",
            with(3, 6, -1.0),
            vec!["rays.npy: row 3: field t: must be >= 0 (or inf), got -1"],
        ),
        (
            "nan-t",
            with(0, 6, f32::NAN),
            vec!["rays.npy: row 0: field t: must be >= 0"],
        ),
        (
            "minus-inf-t",
            with(1, 6, f32::NEG_INFINITY),
            vec!["rays.npy: row 1: field t: must be >= 0", "-inf"],
        ),
    ];
    for (name, bytes, want) in &cases {
        expect_npy_error(name, bytes, &[], want);
    }

    // As for CSV: t = +inf and -0 are accepted, and so is a zero direction.
    let dir = workdir("npy-accepted");
    std::fs::write(dir.join("s.json"), GOOD_SCENE).unwrap();
    let rays = [
        [0.0, 2.0, 0.0, 0.0, 1.0, 0.0, f32::INFINITY],
        [0.0, 2.0, 0.0, 0.0, 1.0, 0.0, -0.0],
        [0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 5.0],
    ];
    std::fs::write(dir.join("r.npy"), rays_npy(&rays)).unwrap();
    let o = eval(&dir, "s.json", "r.npy", "o.npy", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        read_out_npy(&std::fs::read(dir.join("o.npy")).unwrap()).len(),
        3
    );
}

fn good_npy_cut(bytes: &[u8], cut: usize) -> Vec<u8> {
    bytes[..bytes.len() - cut].to_vec()
}

/// A bad row in a late chunk of a .npy file: reported by its row index (counting from 0),
/// the earliest bad row wins, and no output is left behind.
#[test]
fn npy_late_error_leaves_no_output() {
    let mut rays = vec![[0.0f32, 2.0, 0.0, 0.0, -0.5, 1.0, f32::INFINITY]; 50_000];
    rays[40_000][5] = f32::NAN;
    rays[45_000][6] = -3.0;
    let bytes = rays_npy(&rays);
    for chunk in ["1000", "1048576"] {
        expect_npy_error(
            &format!("late-{chunk}"),
            &bytes,
            &["--chunk-rays", chunk],
            &["rays.npy: row 40000: field dz: must be finite, got NaN"],
        );
    }
}

/// `render`: each shipped demo scene gives a PNG of the requested size (read back by the
/// PNG signature and the IHDR chunk), and the time of the fog pass on stderr; a bad
/// render scene is one line naming the file.
#[test]
fn render_demo_scenes() {
    let dir = workdir("render");
    let scenes = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/render");
    for name in ["valley_sunrise.json", "low_fog_backlit.json"] {
        let out = dir.join(format!("{name}.png"));
        let o = run(
            &dir,
            &[
                "render",
                "--scene",
                &format!("{scenes}/{name}"),
                "--width",
                "67",
                "--height",
                "29",
                "--out",
                out.to_str().unwrap(),
            ],
        );
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains("fog pass"), "{}", stderr(&o));
        let png = std::fs::read(&out).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[12..16], b"IHDR");
        let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
        assert_eq!((be(16), be(20)), (67, 29), "{name}: size");
    }
    std::fs::write(
        dir.join("bad.json"),
        br#"{"fog": {}, "camera": {"position": [0,1,0], "look_at": [0,1,-1]}, "colour": 1}"#,
    )
    .unwrap();
    let o = run(&dir, &["render", "--scene", "bad.json", "--out", "x.png"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.starts_with("error: bad.json:1:") && e.contains("colour"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
}
