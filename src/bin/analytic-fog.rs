//! `analytic-fog`: the command-line tool (feature `cli`).
//!
//! ```text
//! analytic-fog eval --scene S.json --rays R.csv --out O.csv
//! analytic-fog info
//! ```
//!
//! `eval` reads a scene (JSON, the serde model of [`SceneDesc`]) and a rays file (CSV with
//! the header `ox,oy,oz,dx,dy,dz,t`), evaluates every ray with [`Scene::evaluate_par`] and
//! writes `tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b`, one row per ray in input order,
//! each f32 in its shortest form that reads back exactly. The rays are streamed in chunks
//! (`--chunk-rays`, default 2^20), so memory stays bounded for any file size.
//!
//! Bad input gives one line on stderr, `error: FILE:LINE: field NAME: what`, exit status
//! 2, and no output file: the output is written to a temporary file next to `--out` and
//! renamed over it only when every ray has been evaluated.

use analytic_fog::{simd_level, Outputs, Rays, Scene, SceneDesc, SceneError};
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand};
use rayon::prelude::*;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufRead, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Exponential height fog, evaluated analytically for batches of rays.
#[derive(Parser, Debug)]
#[command(name = "analytic-fog")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Evaluate a rays CSV file against a scene: optical depth, transmittance and
    /// in-scattered radiance per RGB channel, one output row per ray.
    Eval(EvalArgs),
    /// Print the version, the SIMD level compiled in and the number of threads.
    Info,
}

#[derive(Args, Debug)]
struct EvalArgs {
    /// Scene description (JSON).
    #[arg(long, value_name = "S.json")]
    scene: PathBuf,
    /// Rays, CSV with the header `ox,oy,oz,dx,dy,dz,t` (`inf` accepted for t).
    #[arg(long, value_name = "R.csv")]
    rays: PathBuf,
    /// Output CSV: `tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b`, one row per ray.
    #[arg(long, value_name = "O.csv")]
    out: PathBuf,
    /// Rays read, evaluated and written per chunk (bounds the memory used).
    #[arg(long, value_name = "N", default_value_t = 1 << 20,
          value_parser = clap::value_parser!(u32).range(1..))]
    chunk_rays: u32,
    /// Print nothing on success.
    #[arg(short, long)]
    quiet: bool,
}

const RAYS_HEADER: [&str; 7] = ["ox", "oy", "oz", "dx", "dy", "dz", "t"];
const OUT_HEADER: &str = "tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b";
/// The longest line accepted in a rays file (bytes, newline included).
const MAX_LINE: u64 = 64 * 1024;
/// Rows parsed or formatted per rayon task.
const PAR_ROWS: usize = 8192;

fn main() -> ExitCode {
    let version: &'static str = Box::leak(
        format!("{} (simd {})", env!("CARGO_PKG_VERSION"), simd_level()).into_boxed_str(),
    );
    let cmd = Cli::command().version(version);
    let cli = match Cli::from_arg_matches(&cmd.get_matches()) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    let result = match cli.cmd {
        Cmd::Info => {
            println!("analytic-fog {}", env!("CARGO_PKG_VERSION"));
            println!("simd: {}", simd_level());
            println!("threads: {}", rayon::current_num_threads());
            Ok(())
        }
        Cmd::Eval(args) => eval(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            // Always exactly one line.
            let msg: String = msg
                .chars()
                .map(|c| if c.is_control() { ' ' } else { c })
                .collect();
            eprintln!("error: {msg}");
            ExitCode::from(2)
        }
    }
}

/// An error message (without the `error: ` prefix).
type CliResult<T> = Result<T, String>;

fn eval(args: &EvalArgs) -> CliResult<()> {
    let start = Instant::now();
    let scene = load_scene(&args.scene)?;

    let rays_name = args.rays.display().to_string();
    let file = File::open(&args.rays).map_err(|e| format!("{rays_name}: cannot read: {e}"))?;
    let mut reader = RayReader::new(BufReader::with_capacity(1 << 20, file), rays_name);
    reader.read_header()?;

    let out_name = args.out.display().to_string();
    let mut tmp = TempOut::create(&args.out)?;
    let werr = |e: io::Error| format!("{out_name}: cannot write: {e}");
    let mut w = BufWriter::with_capacity(1 << 20, &tmp.file);
    w.write_all(OUT_HEADER.as_bytes()).map_err(werr)?;
    w.write_all(b"\n").map_err(werr)?;

    let chunk = args.chunk_rays as usize;
    let mut soa = Soa::default();
    let mut n_total = 0u64;
    let mut eval_secs = 0.0f64;
    loop {
        let rows = reader.next_chunk(chunk)?;
        if rows.is_empty() {
            break;
        }
        let parsed = parse_rows(&reader.name, &reader.buf, &rows)?;
        soa.fill(&parsed);
        drop(parsed);
        let t0 = Instant::now();
        soa.evaluate(&scene)
            .map_err(|e| format!("{}: {e}", args.rays.display()))?;
        eval_secs += t0.elapsed().as_secs_f64();
        for block in soa.format() {
            w.write_all(&block).map_err(werr)?;
        }
        n_total += rows.len() as u64;
    }
    w.flush().map_err(werr)?;
    drop(w);
    tmp.commit(&args.out)?;

    if !args.quiet {
        let secs = start.elapsed().as_secs_f64();
        eprintln!(
            "analytic-fog: {n_total} rays in {:.3} ms (evaluation {:.3} ms, {:.1} Mrays/s), simd {}, {} threads -> {out_name}",
            secs * 1e3,
            eval_secs * 1e3,
            if eval_secs > 0.0 { n_total as f64 / eval_secs / 1e6 } else { 0.0 },
            simd_level(),
            rayon::current_num_threads(),
        );
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Scene JSON

fn load_scene(path: &Path) -> CliResult<Scene> {
    let name = path.display();
    let bytes = fs::read(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
    let desc: SceneDesc =
        serde_json::from_slice(&bytes).map_err(|e| json_error(&name.to_string(), &bytes, &e))?;
    Scene::new(desc).map_err(|e| scene_error(&name.to_string(), &bytes, &e))
}

/// `S.json:LINE:COL: field PATH: message` for a serde_json error.
fn json_error(name: &str, text: &[u8], e: &serde_json::Error) -> String {
    let (line, col) = (e.line(), e.column());
    let full = e.to_string();
    let suffix = format!(" at line {line} column {col}");
    let msg = full.strip_suffix(&suffix).unwrap_or(&full);
    if line == 0 {
        return format!("{name}: {msg}");
    }
    let path = json_path_at(text, line_col_offset(text, line, col));
    if path.is_empty() {
        format!("{name}:{line}:{col}: {msg}")
    } else {
        format!("{name}:{line}:{col}: field {path}: {msg}")
    }
}

/// `S.json:LINE: field PATH: message` for a scene that does not validate.
fn scene_error(name: &str, text: &[u8], e: &SceneError) -> String {
    let field = match e {
        SceneError::NonFinite { field, .. }
        | SceneError::Negative { field, .. }
        | SceneError::ZeroVector { field }
        | SceneError::OutOfRange { field, .. }
        | SceneError::Empty { field } => field.as_str(),
    };
    match json_line_of(text, field) {
        Some(line) => format!("{name}:{line}: field {e}"),
        None => format!("{name}: field {e}"),
    }
}

/// The byte offset of serde_json's (1-based line, column) position.
fn line_col_offset(text: &[u8], line: usize, col: usize) -> usize {
    let mut start = 0;
    let mut l = 1;
    for (i, &c) in text.iter().enumerate() {
        if l == line {
            break;
        }
        if c == b'\n' {
            l += 1;
            start = i + 1;
        }
    }
    (start + col).saturating_sub(1)
}

/// An object or array being walked: where its own path ends in the path buffer.
struct Frame {
    is_obj: bool,
    expect_key: bool,
    base: usize,
    index: usize,
}

/// Walks (possibly malformed) JSON text and calls `ev(offset, path)` at the start of every
/// key and value and at the end of every object and array, with the path of that value in
/// the notation of [`SceneError`] (`height_fog[0].components[1].scattering`). Stops when
/// `ev` returns true. Iterative, and the path is kept in one buffer: linear time and no
/// recursion, whatever the nesting.
fn json_walk(text: &[u8], mut ev: impl FnMut(usize, &str) -> bool) {
    use std::fmt::Write as _;
    let mut stack: Vec<Frame> = Vec::new();
    let mut path = String::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        match c {
            b'{' | b'[' => {
                if ev(i, &path) {
                    return;
                }
                let is_obj = c == b'{';
                stack.push(Frame {
                    is_obj,
                    expect_key: is_obj,
                    base: path.len(),
                    index: 0,
                });
                if !is_obj {
                    path.push_str("[0]");
                }
                i += 1;
            }
            b'}' | b']' => {
                let base = stack.pop().map_or(0, |f| f.base);
                path.truncate(base);
                if ev(i, &path) {
                    return;
                }
                i += 1;
            }
            b',' => {
                if let Some(f) = stack.last_mut() {
                    path.truncate(f.base);
                    if f.is_obj {
                        f.expect_key = true;
                    } else {
                        f.index += 1;
                        let _ = write!(path, "[{}]", f.index);
                    }
                }
                i += 1;
            }
            b'"' => {
                let start = i;
                let mut s = Vec::new();
                i += 1;
                while i < text.len() && text[i] != b'"' {
                    if text[i] == b'\\' {
                        i += 1;
                    }
                    if i < text.len() {
                        s.push(text[i]);
                    }
                    i += 1;
                }
                i += 1;
                if let Some(f) = stack.last_mut() {
                    if f.is_obj && f.expect_key {
                        f.expect_key = false;
                        path.truncate(f.base);
                        if f.base > 0 {
                            path.push('.');
                        }
                        path.push_str(&String::from_utf8_lossy(&s));
                    }
                }
                if ev(start, &path) {
                    return;
                }
            }
            b':' => i += 1,
            c if c.is_ascii_whitespace() => i += 1,
            _ => {
                // A number or literal.
                if ev(i, &path) {
                    return;
                }
                while i < text.len() && !b",:{}[]\" \t\r\n".contains(&text[i]) {
                    i += 1;
                }
            }
        }
    }
}

/// The path of the value being read at byte `offset` (for a serde_json error there):
/// that of the last event at or before it.
fn json_path_at(text: &[u8], offset: usize) -> String {
    let mut last = None;
    json_walk(text, |at, _| {
        if at > offset {
            return true;
        }
        last = Some(at);
        false
    });
    let mut path = String::new();
    if let Some(last) = last {
        json_walk(text, |at, p| {
            if at == last {
                path = p.to_string();
            }
            at >= last
        });
    }
    path
}

/// The 1-based line where the value at `field` (or its nearest written ancestor: a
/// channel `scattering[2]` written as one number is found at `scattering`) starts.
fn json_line_of(text: &[u8], field: &str) -> Option<usize> {
    // "height_fog[0].components: extinction[0]" names the components list.
    let field = field.split(':').next().unwrap_or(field).trim();
    let mut candidates = vec![field.to_string()];
    let mut f = field;
    while let Some(cut) = f.rfind(['.', '[']) {
        f = &f[..cut];
        candidates.push(f.to_string());
    }
    let mut found: Vec<Option<usize>> = vec![None; candidates.len()];
    json_walk(text, |at, p| {
        if let Some(k) = candidates.iter().position(|c| c == p) {
            if found[k].is_none() {
                found[k] = Some(at);
            }
        }
        found[0].is_some()
    });
    let at = found.into_iter().flatten().next()?;
    Some(1 + text[..at].iter().filter(|&&c| c == b'\n').count())
}

// ---------------------------------------------------------------------------------------
// Rays CSV

/// One data row of the rays file: its bytes in the chunk buffer and its line number.
struct Row {
    start: usize,
    end: usize,
    line: u64,
}

/// Reads the rays file line by line into a chunk buffer.
struct RayReader<R> {
    inp: R,
    name: String,
    /// Lines read so far.
    line: u64,
    /// The first blank line not yet followed by a row (blank lines are allowed at the
    /// end of the file only).
    blank: Option<u64>,
    buf: Vec<u8>,
}

impl<R: BufRead> RayReader<R> {
    fn new(inp: R, name: String) -> Self {
        RayReader {
            inp,
            name,
            line: 0,
            blank: None,
            buf: Vec::new(),
        }
    }

    /// Reads one line into `self.buf` (appending); false at the end of the file.
    fn read_line(&mut self) -> CliResult<bool> {
        let before = self.buf.len();
        let n = (&mut self.inp)
            .take(MAX_LINE)
            .read_until(b'\n', &mut self.buf)
            .map_err(|e| format!("{}:{}: cannot read: {e}", self.name, self.line + 1))?;
        if n == 0 {
            return Ok(false);
        }
        self.line += 1;
        if n as u64 == MAX_LINE && self.buf.last() != Some(&b'\n') {
            self.buf.truncate(before);
            return Err(format!(
                "{}:{}: line longer than {MAX_LINE} bytes",
                self.name, self.line
            ));
        }
        Ok(true)
    }

    fn read_header(&mut self) -> CliResult<()> {
        self.buf.clear();
        let expected = RAYS_HEADER.join(",");
        if !self.read_line()? {
            return Err(format!(
                "{}:1: field header: the file is empty, expected the header \"{expected}\"",
                self.name
            ));
        }
        let raw = &self.buf[..];
        let raw = raw.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(raw); // UTF-8 BOM
        let got = String::from_utf8_lossy(trim_eol(raw)).into_owned();
        let cols: Vec<&str> = got.split(',').map(str::trim).collect();
        let bad = (0..RAYS_HEADER.len().max(cols.len()))
            .find(|&k| cols.get(k).copied() != RAYS_HEADER.get(k).copied());
        if let Some(k) = bad {
            let field = match RAYS_HEADER.get(k) {
                Some(f) => f.to_string(),
                None => format!("#{}", k + 1),
            };
            return Err(format!(
                "{}:1: field {field}: wrong header: expected \"{expected}\", got {}",
                self.name,
                quoted(&got)
            ));
        }
        Ok(())
    }

    /// Reads up to `max` data rows (fewer only at the end of the file).
    fn next_chunk(&mut self, max: usize) -> CliResult<Vec<Row>> {
        self.buf.clear();
        let mut rows = Vec::new();
        while rows.len() < max {
            let start = self.buf.len();
            if !self.read_line()? {
                break;
            }
            let body = trim_eol(&self.buf[start..]);
            if body.iter().all(u8::is_ascii_whitespace) {
                self.buf.truncate(start);
                self.blank.get_or_insert(self.line);
                continue;
            }
            if let Some(b) = self.blank {
                return Err(format!(
                    "{}:{b}: empty row (blank lines are allowed only at the end of the file)",
                    self.name
                ));
            }
            rows.push(Row {
                start,
                end: start + body.len(),
                line: self.line,
            });
        }
        Ok(rows)
    }
}

fn trim_eol(mut s: &[u8]) -> &[u8] {
    while let [rest @ .., b'\n' | b'\r'] = s {
        s = rest;
    }
    s
}

/// A field's text for an error message: quoted, escaped, at most 40 characters.
fn quoted(s: &str) -> String {
    if s.chars().count() > 40 {
        let cut: String = s.chars().take(40).collect();
        format!("{cut:?}...")
    } else {
        format!("{s:?}")
    }
}

/// Parses one data row into `ox, oy, oz, dx, dy, dz, t`.
fn parse_row(name: &str, line: u64, bytes: &[u8]) -> CliResult<[f32; 7]> {
    let count = 1 + bytes.iter().filter(|&&c| c == b',').count();
    let n = RAYS_HEADER.len();
    if count < n {
        return Err(format!(
            "{name}:{line}: field {}: missing (the row has {count} fields, expected {n})",
            RAYS_HEADER[count],
        ));
    }
    if count > n {
        return Err(format!(
            "{name}:{line}: field #{}: unexpected (the row has {count} fields, expected {n})",
            n + 1,
        ));
    }
    let mut v = [0.0f32; 7];
    for (k, raw) in bytes.split(|&c| c == b',').enumerate() {
        let raw = String::from_utf8_lossy(raw);
        let f = raw.trim();
        let f = f
            .strip_prefix('"')
            .and_then(|s| s.strip_suffix('"'))
            .unwrap_or(f);
        let field = RAYS_HEADER[k];
        let x: f32 = f.parse().map_err(|_| {
            format!(
                "{name}:{line}: field {field}: not a number: {}",
                quoted(&raw)
            )
        })?;
        if k < 6 {
            if !x.is_finite() {
                return Err(format!(
                    "{name}:{line}: field {field}: must be finite, got {}",
                    quoted(&raw)
                ));
            }
        } else if x.is_nan() || x < 0.0 {
            return Err(format!(
                "{name}:{line}: field t: must be >= 0 (or inf), got {}",
                quoted(&raw)
            ));
        }
        v[k] = x;
    }
    Ok(v)
}

/// Parses a chunk's rows in parallel; the error of the earliest bad line wins.
fn parse_rows(name: &str, buf: &[u8], rows: &[Row]) -> CliResult<Vec<[f32; 7]>> {
    let mut out = vec![[0.0f32; 7]; rows.len()];
    let first_err = out
        .par_chunks_mut(PAR_ROWS)
        .zip(rows.par_chunks(PAR_ROWS))
        .filter_map(|(out, rows)| {
            for (o, r) in out.iter_mut().zip(rows) {
                match parse_row(name, r.line, &buf[r.start..r.end]) {
                    Ok(v) => *o = v,
                    Err(e) => return Some((r.line, e)),
                }
            }
            None
        })
        .min_by_key(|(line, _)| *line);
    match first_err {
        Some((_, e)) => Err(e),
        None => Ok(out),
    }
}

// ---------------------------------------------------------------------------------------
// Evaluation and output

/// One chunk's rays and results, structure of arrays, reused between chunks.
#[derive(Default)]
struct Soa {
    /// ox, oy, oz, dx, dy, dz, t.
    input: [Vec<f32>; 7],
    /// tau_r, tau_g, tau_b, T_r, T_g, T_b, in_r, in_g, in_b.
    output: [Vec<f32>; 9],
}

impl Soa {
    fn fill(&mut self, rows: &[[f32; 7]]) {
        for (k, col) in self.input.iter_mut().enumerate() {
            col.clear();
            col.extend(rows.iter().map(|r| r[k]));
        }
        for col in &mut self.output {
            col.clear();
            col.resize(rows.len(), 0.0);
        }
    }

    fn evaluate(&mut self, scene: &Scene) -> Result<(), analytic_fog::BatchError> {
        let [ox, oy, oz, dx, dy, dz, t] = &self.input;
        let rays = Rays::new(ox, oy, oz, dx, dy, dz, t)?;
        let [a, b, c, d, e, f, g, h, i] = &mut self.output;
        scene.evaluate_par(
            &rays,
            Outputs {
                tau: Some([a, b, c]),
                transmittance: Some([d, e, f]),
                inscattering: Some([g, h, i]),
            },
        )
    }

    /// The chunk's output rows as CSV text, in blocks formatted in parallel.
    fn format(&self) -> Vec<Vec<u8>> {
        let n = self.output[0].len();
        (0..n.div_ceil(PAR_ROWS))
            .into_par_iter()
            .map(|b| {
                let mut s = Vec::with_capacity(PAR_ROWS * 96);
                let mut fbuf = zmij::Buffer::new();
                for r in b * PAR_ROWS..((b + 1) * PAR_ROWS).min(n) {
                    for (k, col) in self.output.iter().enumerate() {
                        if k > 0 {
                            s.push(b',');
                        }
                        write_f32(&mut s, &mut fbuf, col[r]);
                    }
                    s.push(b'\n');
                }
                s
            })
            .collect()
    }
}

/// Writes `x` in the shortest decimal form that reads back as exactly `x` (zmij, the
/// formatter serde_json uses: `0.057505865`, `1.0`, `1.5e-30`); `inf` for +∞.
fn write_f32(s: &mut Vec<u8>, buf: &mut zmij::Buffer, x: f32) {
    s.extend_from_slice(buf.format(x).as_bytes());
}

/// The output file under construction: a temporary file next to `--out`, removed on
/// drop unless [`TempOut::commit`] renamed it into place.
struct TempOut {
    path: PathBuf,
    file: File,
    done: bool,
}

impl TempOut {
    fn create(out: &Path) -> CliResult<TempOut> {
        let name = out.display();
        let file_name = out
            .file_name()
            .ok_or_else(|| format!("{name}: not a file name"))?;
        let path = out.with_file_name(format!(
            ".{}.{}.tmp",
            file_name.to_string_lossy(),
            std::process::id()
        ));
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| format!("{name}: cannot create {}: {e}", path.display()))?;
        Ok(TempOut {
            path,
            file,
            done: false,
        })
    }

    fn commit(&mut self, out: &Path) -> CliResult<()> {
        fs::rename(&self.path, out).map_err(|e| format!("{}: cannot write: {e}", out.display()))?;
        self.done = true;
        Ok(())
    }
}

impl Drop for TempOut {
    fn drop(&mut self) {
        if !self.done {
            let _ = fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_paths() {
        let text = br#"{ "up": [0, 1, 0],
  "height_fog": [ { "base_height": 0.0, "falloff": 0.08,
      "components": [ { "scattering": 0.02, "absorption": [0, -1, 0] } ] } ] }"#;
        assert_eq!(json_line_of(text, "up[1]"), Some(1));
        assert_eq!(json_line_of(text, "height_fog[0].falloff"), Some(2));
        assert_eq!(
            json_line_of(text, "height_fog[0].components[0].absorption[1]"),
            Some(3)
        );
        // Written as one number: found at its parent.
        assert_eq!(
            json_line_of(text, "height_fog[0].components[0].scattering[2]"),
            Some(3)
        );
        assert_eq!(
            json_line_of(text, "height_fog[0].components: extinction[0]"),
            Some(3)
        );
        let s = std::str::from_utf8(text).unwrap();
        let at = s.find("-1").unwrap();
        assert_eq!(
            json_path_at(text, at),
            "height_fog[0].components[0].absorption[1]"
        );
        let at = s.find("0.08").unwrap();
        assert_eq!(json_path_at(text, at), "height_fog[0].falloff");
        // Deep or broken nesting does not recurse.
        let deep = vec![b'['; 100_000];
        assert!(json_path_at(&deep, 99_999).ends_with("[0]"));
        assert_eq!(json_path_at(b"\"abc", 3), "");
    }

    #[test]
    fn rows() {
        let r = parse_row("r.csv", 2, b" 1, 2.5,-3,0,+1e-3,1,inf").unwrap();
        assert_eq!(r, [1.0, 2.5, -3.0, 0.0, 1e-3, 1.0, f32::INFINITY]);
        for t in ["+inf", "Infinity", "INF", "-0"] {
            let row = format!("0,0,0,0,1,0,{t}");
            assert!(parse_row("r.csv", 2, row.as_bytes()).is_ok(), "{t}");
        }
        for (row, want) in [
            (
                "0,0,0,0,abc,0,1",
                "r.csv:2: field dy: not a number: \"abc\"",
            ),
            ("0,0,0,0,1,0", "r.csv:2: field t: missing"),
            ("0,0,0,0,1,0,1,2", "r.csv:2: field #8: unexpected"),
            ("0,0,NaN,0,1,0,1", "r.csv:2: field oz: must be finite"),
            ("0,0,0,inf,1,0,1", "r.csv:2: field dx: must be finite"),
            ("0,0,0,0,1,0,-1", "r.csv:2: field t: must be >= 0"),
            ("0,0,0,0,1,0,nan", "r.csv:2: field t: must be >= 0"),
            ("0,0,0,0,1,0,-inf", "r.csv:2: field t: must be >= 0"),
        ] {
            let e = parse_row("r.csv", 2, row.as_bytes()).unwrap_err();
            assert!(e.starts_with(want), "{row}: {e}");
        }
    }

    #[test]
    fn f32_round_trip() {
        let (mut s, mut buf) = (Vec::new(), zmij::Buffer::new());
        let special = [
            0.0f32,
            1.0,
            0.1,
            1e-5,
            1e9,
            f32::MAX,
            1e-45,
            f32::MIN_POSITIVE,
        ];
        // Every exponent, several mantissas each (a deterministic LCG).
        let mut r = 12345u32;
        let lcg = (0..200_000).map(|_| {
            r = r.wrapping_mul(1664525).wrapping_add(1013904223);
            f32::from_bits(r & 0x7fff_ffff)
        });
        for x in special.into_iter().chain(lcg).chain([f32::INFINITY]) {
            if x.is_nan() {
                continue;
            }
            s.clear();
            write_f32(&mut s, &mut buf, x);
            let t = std::str::from_utf8(&s).unwrap();
            assert_eq!(t.parse::<f32>().unwrap().to_bits(), x.to_bits(), "{t}");
            assert!(t.len() <= 16, "{t}");
        }
        s.clear();
        write_f32(&mut s, &mut buf, f32::INFINITY);
        assert_eq!(s, b"inf");
    }
}
