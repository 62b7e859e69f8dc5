//! `analytic-fog`: the command-line tool (feature `cli`).
//!
//! ```text
//! analytic-fog report [--out-dir DIR] [--rays N] [--kernel NAME]
//! analytic-fog eval --scene S.json --rays R.csv --out O.csv
//! analytic-fog info
//! ```
//!
//! `report` measures error against run time for every kernel and method and writes a
//! table (stdout), JSON, CSV and charts (`analytic_fog::report`).
//!
//! `eval` reads a scene (JSON, the serde model of [`analytic_fog::SceneDesc`]) and a rays
//! file (CSV with the header `ox,oy,oz,dx,dy,dz,t`, or NumPy `.npy`, N×7 float32, in
//! those columns), evaluates every ray with [`Scene::evaluate_par`] and writes
//! `tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b`, one row per ray in input order (CSV:
//! each f32 in its shortest form that reads back exactly; `.npy`: N×9 float32). The
//! format of each file is chosen by its extension (`.npy`, any case, or CSV). The rays
//! are streamed in chunks (`--chunk-rays`, default 2^20), so memory stays bounded for any
//! file size.
//!
//! Modules: `scene` (the scene JSON and its error positions), `csv` and `npy` (the two
//! file formats).
//!
//! Bad input gives one line on stderr, `error: FILE:LINE: field NAME: what` (`.npy`:
//! `error: FILE: row R: field NAME: what`, or what is wrong with the header), exit status
//! 2, and no output file: the output is written to a temporary file next to `--out` and
//! renamed over it only when every ray has been evaluated.

mod csv;
mod npy;
mod render;
mod scene;

use analytic_fog::{simd_level, Outputs, Rays, Scene};
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand};
use scene::load_scene;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufReader, BufWriter, IsTerminal, Write};
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
    /// Measure error against run time for every kernel and method (the crate's kernels,
    /// the f64 reference, the seeds' formulas, ray marching), with the stability sweeps:
    /// a table on stdout; report.json, report.csv and SVG/PNG charts in --out-dir.
    Report(ReportArgs),
    /// Render a demo image: a small ray caster (terrain or ground plane, spheres, sky)
    /// fogged by the framebuffer pass, written as PNG; prints the fog pass's time.
    Render(RenderArgs),
    /// Evaluate a rays file (CSV or .npy) against a scene: optical depth, transmittance and
    /// in-scattered radiance per RGB channel, one output row per ray.
    Eval(EvalArgs),
    /// Print the version, the SIMD level compiled in and the number of threads.
    Info,
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// Render scene (JSON): {"fog": <scene>, "camera": {...}, "sky", "terrain", "spheres",
    /// "exposure"}; see examples/render/.
    #[arg(long, value_name = "S.json")]
    scene: PathBuf,
    /// Image width in pixels.
    #[arg(long, value_name = "W", default_value_t = 960,
          value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,
    /// Image height in pixels.
    #[arg(long, value_name = "H", default_value_t = 540,
          value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,
    /// Output PNG.
    #[arg(long, value_name = "image.png")]
    out: PathBuf,
    /// Print nothing on success.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct ReportArgs {
    /// Where report.json, report.csv, stability.csv and the charts are written.
    #[arg(long, value_name = "DIR", default_value = "target/report")]
    out_dir: PathBuf,
    /// Rays per ray set (typical and extreme, per kernel); ray marching with 64 or more
    /// steps uses the first 4096 of them.
    #[arg(long, value_name = "N", default_value_t = 1 << 15,
          value_parser = clap::value_parser!(u32).range(64..=(1 << 24)))]
    rays: u32,
    /// Fewest timing repeats per measurement (the median is reported; short measurements
    /// repeat until 30 ms are spent).
    #[arg(long, value_name = "R", default_value_t = 7,
          value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeats: u32,
    /// Only the kernels whose name contains this (e.g. `height_fog`, `volume_gaussian`).
    #[arg(long, value_name = "NAME")]
    kernel: Option<String>,
    /// No progress lines on stderr.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args, Debug)]
struct EvalArgs {
    /// Scene description (JSON).
    #[arg(long, value_name = "S.json")]
    scene: PathBuf,
    /// Rays: CSV with the header `ox,oy,oz,dx,dy,dz,t` (`inf` accepted for t), or, for a
    /// name ending in `.npy`, a NumPy array of N×7 little-endian float32 in those columns.
    #[arg(long, value_name = "R.csv|R.npy")]
    rays: PathBuf,
    /// Output: CSV `tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b`, one row per ray, or,
    /// for a name ending in `.npy`, a NumPy array of N×9 float32 in those columns.
    #[arg(long, value_name = "O.csv|O.npy")]
    out: PathBuf,
    /// Rays read, evaluated and written per chunk (bounds the memory used).
    #[arg(long, value_name = "N", default_value_t = 1 << 20,
          value_parser = clap::value_parser!(u32).range(1..))]
    chunk_rays: u32,
    /// Print nothing on success.
    #[arg(short, long)]
    quiet: bool,
    /// Report progress on stderr after every chunk (without it: only on a terminal, not
    /// with -q, and once the run has taken a second).
    #[arg(long)]
    progress: bool,
}

/// The SIMD level compiled in, and the run-time AVX-512 dispatch where it happens (see
/// `analytic_fog::avx512_dispatch`): "avx2+fma", "avx2+fma, avx512 at run time".
fn simd() -> String {
    if analytic_fog::avx512_dispatch() {
        format!("{}, avx512 at run time", simd_level())
    } else {
        simd_level().to_string()
    }
}

fn main() -> ExitCode {
    let version: &'static str =
        Box::leak(format!("{} (simd {})", env!("CARGO_PKG_VERSION"), simd()).into_boxed_str());
    let cmd = Cli::command().version(version);
    let cli = match Cli::from_arg_matches(&cmd.get_matches()) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    let result = match cli.cmd {
        Cmd::Info => {
            println!("analytic-fog {}", env!("CARGO_PKG_VERSION"));
            println!("simd: {}", simd());
            println!("threads: {}", rayon::current_num_threads());
            Ok(())
        }
        Cmd::Eval(args) => eval(&args),
        Cmd::Report(args) => report(&args),
        Cmd::Render(a) => render::render(&a.scene, a.width, a.height, &a.out, a.quiet),
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

fn report(args: &ReportArgs) -> CliResult<()> {
    use analytic_fog::report;
    let opts = report::Options {
        out_dir: args.out_dir.clone(),
        rays: args.rays as usize,
        repeats: args.repeats as usize,
        filter: args.kernel.clone(),
        ..report::Options::default()
    };
    let t0 = Instant::now();
    eprintln!(
        "analytic-fog report: simd {}, {} threads, {} rays per set",
        simd(),
        rayon::current_num_threads(),
        opts.rays
    );
    let quiet = args.quiet;
    let r = report::run(&opts, &mut |line| {
        if !quiet {
            eprintln!("{:7.1}s  {line}", t0.elapsed().as_secs_f64());
        }
    })?;
    println!("{}", report::table(&r));
    eprintln!(
        "analytic-fog report: {:.1} s; wrote {}",
        r.elapsed.as_secs_f64(),
        r.files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}

/// An error message (without the `error: ` prefix).
type CliResult<T> = Result<T, String>;

/// The columns of a rays file, in order (the CSV header, the `.npy` columns).
const RAYS_COLUMNS: [&str; 7] = ["ox", "oy", "oz", "dx", "dy", "dz", "t"];
/// The columns of an output file, in order (the CSV header, the `.npy` columns).
const OUT_COLUMNS: [&str; 9] = [
    "tau_r", "tau_g", "tau_b", "T_r", "T_g", "T_b", "in_r", "in_g", "in_b",
];
/// Rows parsed, decoded or formatted per rayon task.
const PAR_ROWS: usize = 8192;

/// What is wrong with value `x` in column `k` of a ray (`None`: nothing), the same rule
/// for CSV and `.npy`: `ox oy oz dx dy dz` finite, `t` >= 0 or +inf.
fn ray_field_problem(k: usize, x: f32) -> Option<&'static str> {
    if k < 6 {
        (!x.is_finite()).then_some("must be finite")
    } else {
        (x.is_nan() || x < 0.0).then_some("must be >= 0 (or inf)")
    }
}

fn eval(args: &EvalArgs) -> CliResult<()> {
    let start = Instant::now();
    let scene = load_scene(&args.scene)?;
    let rays_name = args.rays.display().to_string();
    let mut input = Input::open(&args.rays)?;

    let out_name = args.out.display().to_string();
    let mut tmp = TempOut::create(&args.out)?;
    let mut output = Output::new(&tmp.file, &args.out)?;

    let chunk = args.chunk_rays as usize;
    let mut soa = Soa::default();
    let mut progress = Progress::new(args);
    let mut n_total = 0u64;
    let mut eval_secs = 0.0f64;
    loop {
        let n = input.next_chunk(chunk, &mut soa)?;
        if n == 0 {
            break;
        }
        let t0 = Instant::now();
        soa.evaluate(&scene)
            .map_err(|e| format!("{rays_name}: {e}"))?;
        eval_secs += t0.elapsed().as_secs_f64();
        output.write_chunk(&soa.output)?;
        n_total += n as u64;
        progress.update(&input, n_total);
    }
    output.finish()?;
    tmp.commit(&args.out)?;
    progress.finish();

    if !args.quiet {
        let secs = start.elapsed().as_secs_f64();
        eprintln!(
            "analytic-fog: {n_total} rays in {:.3} ms (evaluation {:.3} ms, {:.1} Mrays/s), simd {}, {} threads -> {out_name}",
            secs * 1e3,
            eval_secs * 1e3,
            if eval_secs > 0.0 { n_total as f64 / eval_secs / 1e6 } else { 0.0 },
            simd(),
            rayon::current_num_threads(),
        );
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Input and output formats, chosen by the file name's extension

/// The rays being read.
enum Input {
    /// A CSV file, and its size in bytes where known (for the progress report).
    Csv(csv::RayReader<BufReader<File>>, Option<u64>),
    Npy(npy::NpyReader),
}

impl Input {
    fn open(path: &Path) -> CliResult<Input> {
        if npy::is_npy(path) {
            return Ok(Input::Npy(npy::NpyReader::open(path)?));
        }
        let name = path.display().to_string();
        let file = File::open(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
        let size = file
            .metadata()
            .ok()
            .filter(|m| m.is_file())
            .map(|m| m.len());
        let mut reader = csv::RayReader::new(BufReader::with_capacity(1 << 20, file), name);
        reader.read_header()?;
        Ok(Input::Csv(reader, size))
    }

    /// Reads up to `max` rays into `soa` (sized for them); 0 at the end of the rays.
    fn next_chunk(&mut self, max: usize, soa: &mut Soa) -> CliResult<usize> {
        let n = match self {
            Input::Csv(reader, _) => {
                let rows = reader.next_chunk(max)?;
                let parsed = csv::parse_rows(&reader.name, &reader.buf, &rows)?;
                soa.fill(&parsed);
                rows.len()
            }
            Input::Npy(reader) => reader.next_chunk(max, &mut soa.input)?,
        };
        soa.size_output(n);
        Ok(n)
    }
}

/// The results being written (to the temporary file).
enum Output<'a> {
    Csv(BufWriter<&'a File>, String),
    Npy(npy::NpyWriter<'a>),
}

impl<'a> Output<'a> {
    /// Starts the output: writes the CSV header, or a `.npy` header to be completed by
    /// [`Output::finish`].
    fn new(file: &'a File, path: &Path) -> CliResult<Output<'a>> {
        let name = path.display().to_string();
        if npy::is_npy(path) {
            return Ok(Output::Npy(npy::NpyWriter::new(file, name)?));
        }
        let mut w = BufWriter::with_capacity(1 << 20, file);
        let header = format!("{}\n", csv::out_header());
        w.write_all(header.as_bytes())
            .map_err(|e| format!("{name}: cannot write: {e}"))?;
        Ok(Output::Csv(w, name))
    }

    fn write_chunk(&mut self, output: &[Vec<f32>; 9]) -> CliResult<()> {
        match self {
            Output::Csv(w, name) => {
                for block in csv::format_rows(output) {
                    w.write_all(&block)
                        .map_err(|e| format!("{name}: cannot write: {e}"))?;
                }
                Ok(())
            }
            Output::Npy(w) => w.write_chunk(output),
        }
    }

    fn finish(self) -> CliResult<()> {
        match self {
            Output::Csv(mut w, name) => w.flush().map_err(|e| format!("{name}: cannot write: {e}")),
            Output::Npy(w) => w.finish(),
        }
    }
}

/// The progress report on stderr: one report after every chunk, `\r`-overwritten on a
/// terminal. On with `--progress`; otherwise only when stderr is a terminal, `-q` is not
/// given and the run has taken more than a second.
struct Progress {
    on: bool,
    tty: bool,
    delay_secs: f64,
    start: Instant,
    /// A `\r` report is on the terminal's last line (end it before anything else).
    pending: bool,
}

impl Progress {
    fn new(args: &EvalArgs) -> Progress {
        let tty = io::stderr().is_terminal();
        Progress {
            on: args.progress || (tty && !args.quiet),
            tty,
            delay_secs: if args.progress { 0.0 } else { 1.0 },
            start: Instant::now(),
            pending: false,
        }
    }

    fn update(&mut self, input: &Input, done: u64) {
        let secs = self.start.elapsed().as_secs_f64();
        if !self.on || secs < self.delay_secs {
            return;
        }
        let msg = match input {
            Input::Npy(r) => {
                let total = r.rows();
                let pct = if total > 0 {
                    100.0 * done as f64 / total as f64
                } else {
                    100.0
                };
                format!("analytic-fog: {done} / {total} rays ({pct:.1}%), {secs:.1} s")
            }
            Input::Csv(r, Some(size)) if *size > 0 => {
                let pct = 100.0 * r.bytes_read as f64 / *size as f64;
                format!(
                    "analytic-fog: {done} rays ({pct:.1}% of {}), {secs:.1} s",
                    r.name
                )
            }
            Input::Csv(..) => format!("analytic-fog: {done} rays, {secs:.1} s"),
        };
        if self.tty {
            eprint!("\r{msg}\x1b[K");
            self.pending = true;
        } else {
            eprintln!("{msg}");
        }
    }

    fn finish(&mut self) {
        if self.pending {
            eprintln!();
            self.pending = false;
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

// ---------------------------------------------------------------------------------------
// Evaluation

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
    }

    fn size_output(&mut self, n: usize) {
        for col in &mut self.output {
            col.clear();
            col.resize(n, 0.0);
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
