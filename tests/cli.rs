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
