//! NumPy `.npy` files: rays in (N×7 float32, the columns `ox,oy,oz,dx,dy,dz,t`), results
//! out (N×9 float32, `tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b`).
//!
//! The format (numpy's `numpy/lib/format.py`): the magic `\x93NUMPY`, a major and a minor
//! version byte, the header length (u16 little-endian in version 1.0, u32 in 2.0 and
//! 3.0), the header (a Python dict literal `{'descr': '<f4', 'fortran_order': False,
//! 'shape': (N, 7), }`, padded with spaces and ended with `\n`; Latin-1 in 1.0 and 2.0,
//! UTF-8 in 3.0), then the data, row after row in C order.
//!
//! Rays are read in chunks straight from the file (no whole-file buffer); the output's
//! header is written first with a placeholder row count and rewritten, same length, once
//! the number of rows is known.

use crate::{ray_field_problem, CliResult, PAR_ROWS, RAYS_COLUMNS};
use rayon::prelude::*;
use std::fs::File;
use std::io::{self, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;

const MAGIC: &[u8; 6] = b"\x93NUMPY";
/// The longest header accepted (numpy itself refuses more than 10 000 bytes by default).
const MAX_HEADER: u64 = 1 << 20;
/// Bytes per rays row: 7 float32.
const IN_ROW: usize = 7 * 4;
/// Bytes per output row: 9 float32.
const OUT_ROW: usize = 9 * 4;
/// The output's header length, magic to `\n`: enough for any u64 row count, a multiple of
/// 64 as numpy writes it.
const OUT_HEADER_LEN: usize = 128;

/// Whether `path` names a `.npy` file (by its extension, in any case).
pub(crate) fn is_npy(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
}

// ---------------------------------------------------------------------------------------
// The header

/// A Python literal, as far as `.npy` headers use them.
#[derive(Debug, Clone, PartialEq)]
enum Py {
    Str(String),
    Int(i128),
    Bool(bool),
    None,
    Tuple(Vec<Py>),
    List(Vec<Py>),
    Dict(Vec<(Py, Py)>),
}

impl Py {
    /// The value written back as Python would print it (for error messages).
    fn repr(&self) -> String {
        let seq = |v: &[Py]| v.iter().map(Py::repr).collect::<Vec<_>>().join(", ");
        match self {
            Py::Str(s) => format!("'{}'", s.escape_debug()),
            Py::Int(i) => i.to_string(),
            Py::Bool(b) => if *b { "True" } else { "False" }.to_string(),
            Py::None => "None".to_string(),
            Py::Tuple(v) if v.len() == 1 => format!("({},)", v[0].repr()),
            Py::Tuple(v) => format!("({})", seq(v)),
            Py::List(v) => format!("[{}]", seq(v)),
            Py::Dict(v) => {
                let items: Vec<String> = v
                    .iter()
                    .map(|(k, x)| format!("{}: {}", k.repr(), x.repr()))
                    .collect();
                format!("{{{}}}", items.join(", "))
            }
        }
    }
}

/// A recursive-descent parser of the Python literals in a header.
struct Lit<'a> {
    s: &'a [u8],
    i: usize,
}

impl Lit<'_> {
    fn peek(&mut self) -> Option<u8> {
        while self.s.get(self.i).is_some_and(u8::is_ascii_whitespace) {
            self.i += 1;
        }
        self.s.get(self.i).copied()
    }

    fn err(&self, what: &str) -> String {
        format!("{what} at byte {} of the header", self.i)
    }

    fn value(&mut self, depth: u32) -> Result<Py, String> {
        if depth > 32 {
            return Err(self.err("nested too deeply"));
        }
        let c = match self.peek() {
            Some(c) => c,
            None => return Err(self.err("unexpected end")),
        };
        match c {
            b'{' => {
                self.i += 1;
                let mut items = Vec::new();
                loop {
                    if self.peek() == Some(b'}') {
                        self.i += 1;
                        return Ok(Py::Dict(items));
                    }
                    let k = self.value(depth + 1)?;
                    if self.peek() != Some(b':') {
                        return Err(self.err("expected ':'"));
                    }
                    self.i += 1;
                    let v = self.value(depth + 1)?;
                    items.push((k, v));
                    match self.peek() {
                        Some(b',') => self.i += 1,
                        Some(b'}') => {}
                        _ => return Err(self.err("expected ',' or '}'")),
                    }
                }
            }
            b'(' | b'[' => {
                let close = if c == b'(' { b')' } else { b']' };
                self.i += 1;
                let mut items = Vec::new();
                let mut comma = false;
                loop {
                    if self.peek() == Some(close) {
                        self.i += 1;
                        break;
                    }
                    items.push(self.value(depth + 1)?);
                    match self.peek() {
                        Some(b',') => {
                            self.i += 1;
                            comma = true;
                        }
                        Some(x) if x == close => {}
                        _ => return Err(self.err(&format!("expected ',' or '{}'", close as char))),
                    }
                }
                Ok(match c {
                    // `(x)` is x itself, as in Python.
                    b'(' if items.len() == 1 && !comma => items.pop().unwrap_or(Py::None),
                    b'(' => Py::Tuple(items),
                    _ => Py::List(items),
                })
            }
            b'\'' | b'"' => {
                self.i += 1;
                let mut bytes = Vec::new();
                loop {
                    match self.s.get(self.i) {
                        None => return Err(self.err("unterminated string")),
                        Some(&x) if x == c => break,
                        Some(b'\\') => {
                            self.i += 1;
                            if let Some(&x) = self.s.get(self.i) {
                                bytes.push(x);
                            }
                        }
                        Some(&x) => bytes.push(x),
                    }
                    self.i += 1;
                }
                self.i += 1;
                Ok(Py::Str(String::from_utf8_lossy(&bytes).into_owned()))
            }
            b'-' | b'+' | b'0'..=b'9' => {
                let neg = c == b'-';
                if !c.is_ascii_digit() {
                    self.i += 1;
                }
                let mut v: i128 = 0;
                let mut digits = 0;
                while let Some(&x) = self.s.get(self.i) {
                    if x.is_ascii_digit() {
                        v = v
                            .checked_mul(10)
                            .and_then(|v| v.checked_add(i128::from(x - b'0')))
                            .ok_or_else(|| self.err("integer too large"))?;
                        digits += 1;
                    } else if x != b'_' {
                        break;
                    }
                    self.i += 1;
                }
                if digits == 0 {
                    return Err(self.err("expected a number"));
                }
                // Python 2's long integers (`3L`), as old numpy wrote them.
                if matches!(self.s.get(self.i), Some(b'L' | b'l')) {
                    self.i += 1;
                }
                if matches!(self.s.get(self.i), Some(b'.' | b'e' | b'E' | b'j' | b'J')) {
                    return Err(self.err("expected an integer"));
                }
                Ok(Py::Int(if neg { -v } else { v }))
            }
            b'A'..=b'Z' | b'a'..=b'z' | b'_' => {
                let start = self.i;
                while self
                    .s
                    .get(self.i)
                    .is_some_and(|x| x.is_ascii_alphanumeric() || *x == b'_')
                {
                    self.i += 1;
                }
                match &self.s[start..self.i] {
                    b"True" => Ok(Py::Bool(true)),
                    b"False" => Ok(Py::Bool(false)),
                    b"None" => Ok(Py::None),
                    w => {
                        self.i = start;
                        Err(self.err(&format!("unknown name {:?}", String::from_utf8_lossy(w))))
                    }
                }
            }
            _ => Err(self.err(&format!("unexpected character {:?}", c as char))),
        }
    }
}

/// The parts of a header that matter, checked to be of the right types.
#[derive(Debug, PartialEq)]
struct Header {
    /// The dtype, as written (`'<f4'`), or a structured one (a list).
    descr: Py,
    fortran_order: bool,
    shape: Vec<u64>,
}

/// Parses a header dict; the error says what is wrong (without the file name).
fn parse_header(text: &[u8]) -> Result<Header, String> {
    let mut p = Lit { s: text, i: 0 };
    let dict = p.value(0)?;
    if p.peek().is_some() {
        return Err(p.err("unexpected text after the dict"));
    }
    let items = match dict {
        Py::Dict(items) => items,
        other => return Err(format!("expected a dict, got {}", short(&other.repr()))),
    };
    let (mut descr, mut fortran_order, mut shape) = (None, None, None);
    for (k, v) in items {
        let slot = match &k {
            Py::Str(s) if s == "descr" => &mut descr,
            Py::Str(s) if s == "fortran_order" => &mut fortran_order,
            Py::Str(s) if s == "shape" => &mut shape,
            _ => {
                return Err(format!(
                    "unexpected key {} (the keys are 'descr', 'fortran_order' and 'shape')",
                    short(&k.repr())
                ))
            }
        };
        if slot.is_some() {
            return Err(format!("key {} given twice", k.repr()));
        }
        *slot = Some(v);
    }
    let missing = |key: &str| format!("key '{key}' missing");
    let descr = descr.ok_or_else(|| missing("descr"))?;
    let fortran_order = match fortran_order.ok_or_else(|| missing("fortran_order"))? {
        Py::Bool(b) => b,
        other => {
            return Err(format!(
                "field fortran_order: expected True or False, got {}",
                short(&other.repr())
            ))
        }
    };
    let shape_py = shape.ok_or_else(|| missing("shape"))?;
    let bad_shape = || {
        format!(
            "field shape: expected a tuple of non-negative integers, got {}",
            short(&shape_py.repr())
        )
    };
    let shape = match &shape_py {
        Py::Tuple(v) => v
            .iter()
            .map(|x| match x {
                Py::Int(i) => u64::try_from(*i).map_err(|_| bad_shape()),
                _ => Err(bad_shape()),
            })
            .collect::<Result<Vec<u64>, String>>()?,
        _ => return Err(bad_shape()),
    };
    match &descr {
        Py::Str(_) | Py::List(_) => {}
        other => {
            return Err(format!(
                "field descr: expected a dtype string, got {}",
                short(&other.repr())
            ))
        }
    }
    Ok(Header {
        descr,
        fortran_order,
        shape,
    })
}

/// At most 80 characters of `s`, for an error message.
fn short(s: &str) -> String {
    if s.chars().count() > 80 {
        format!("{}...", s.chars().take(80).collect::<String>())
    } else {
        s.to_string()
    }
}

/// A dtype string in words: `'<f8'` is "little-endian float64".
fn describe_dtype(d: &str) -> String {
    let (order, rest) = match d.as_bytes().first() {
        Some(b'<') => ("little-endian ", &d[1..]),
        Some(b'>') => ("big-endian ", &d[1..]),
        Some(b'=') => ("native-endian ", &d[1..]),
        Some(b'|') => ("", &d[1..]),
        _ => ("", d),
    };
    let kind = match rest.as_bytes().first() {
        Some(b'f') => "float",
        Some(b'i') => "int",
        Some(b'u') => "uint",
        Some(b'c') => "complex",
        Some(b'b') => return "bool".to_string(),
        Some(b'U') => return "unicode string".to_string(),
        Some(b'S') => return "byte string".to_string(),
        Some(b'O') => return "Python object".to_string(),
        _ => return "unknown type".to_string(),
    };
    match rest[1..].parse::<u64>() {
        Ok(bytes) => format!("{order}{kind}{}", bytes.saturating_mul(8)),
        Err(_) => format!("{order}{kind}"),
    }
}

/// Whether a dtype string means little-endian float32 here.
fn is_f32_le(d: &str) -> bool {
    d == "<f4" || (cfg!(target_endian = "little") && (d == "=f4" || d == "f4"))
}

fn shape_repr(shape: &[u64]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(u64::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Reads until `buf` is full or the end of the file; the number of bytes read.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

// ---------------------------------------------------------------------------------------
// Reading rays

/// A `.npy` rays file whose header has been read and checked.
pub(crate) struct NpyReader {
    file: File,
    name: String,
    shape: Vec<u64>,
    /// Rows the header promises.
    rows: u64,
    /// Rows read so far.
    done: u64,
    buf: Vec<u8>,
}

impl NpyReader {
    /// Opens the file and checks its header: float32, C order, shape (N, 7), and (for a
    /// regular file) exactly N rows of data.
    pub(crate) fn open(path: &Path) -> CliResult<NpyReader> {
        let name = path.display().to_string();
        let rerr = |e: io::Error| format!("{name}: cannot read: {e}");
        let mut file = File::open(path).map_err(rerr)?;

        let mut pre = [0u8; 12];
        let got = read_full(&mut file, &mut pre[..10]).map_err(rerr)?;
        if got < 8 || &pre[..6] != MAGIC {
            let what = if got == 0 {
                "the file is empty".to_string()
            } else if got < 8 && MAGIC.starts_with(&pre[..got.min(6)]) {
                format!("the file ends after {got} bytes")
            } else {
                format!("bad magic \"{}\"", pre[..got.min(6)].escape_ascii())
            };
            return Err(format!(
                "{name}: not a .npy file: {what} (expected the magic \"\\x93NUMPY\")"
            ));
        }
        let (major, minor) = (pre[6], pre[7]);
        let prelude = match (major, minor) {
            (1, 0) => 10,
            (2, 0) | (3, 0) => 12,
            _ => {
                return Err(format!(
                    "{name}: unsupported .npy format version {major}.{minor} (supported: 1.0, 2.0, 3.0)"
                ))
            }
        };
        let got = got + read_full(&mut file, &mut pre[got..prelude]).map_err(rerr)?;
        if got < prelude {
            return Err(format!(
                "{name}: truncated header: the file ends after {got} bytes"
            ));
        }
        let header_len = if prelude == 10 {
            u64::from(u16::from_le_bytes([pre[8], pre[9]]))
        } else {
            u64::from(u32::from_le_bytes([pre[8], pre[9], pre[10], pre[11]]))
        };
        if header_len > MAX_HEADER {
            return Err(format!(
                "{name}: bad header: {header_len} bytes long (at most {MAX_HEADER} accepted)"
            ));
        }
        let mut text = vec![0u8; header_len as usize];
        let got = read_full(&mut file, &mut text).map_err(rerr)?;
        if got < text.len() {
            return Err(format!(
                "{name}: truncated header: {header_len} bytes promised, the file ends after {got}"
            ));
        }
        let h = parse_header(&text).map_err(|e| {
            let shown = String::from_utf8_lossy(&text);
            format!("{name}: bad header: {e}: {:?}", short(shown.trim_end()))
        })?;

        let descr = match &h.descr {
            Py::Str(d) => d.clone(),
            other => {
                return Err(format!(
                    "{name}: header field descr: structured dtype {} is not supported: expected '<f4' (little-endian float32)",
                    short(&other.repr())
                ))
            }
        };
        if !is_f32_le(&descr) {
            return Err(format!(
                "{name}: header field descr: dtype '{}' ({}) is not supported: expected '<f4' (little-endian float32; numpy: rays.astype('<f4'))",
                descr.escape_debug(),
                describe_dtype(&descr)
            ));
        }
        if h.fortran_order {
            return Err(format!(
                "{name}: header field fortran_order: True is not supported: expected C order (numpy: np.ascontiguousarray(rays))"
            ));
        }
        let shape_s = shape_repr(&h.shape);
        let rows = match h.shape[..] {
            [n, 7] => n,
            [_, c] => {
                return Err(format!(
                    "{name}: header field shape: {shape_s} has {c} columns: expected (N, 7), the columns {}",
                    RAYS_COLUMNS.join(",")
                ))
            }
            _ => {
                return Err(format!(
                    "{name}: header field shape: {shape_s} has {} dimension{}: expected (N, 7), the columns {}",
                    h.shape.len(),
                    if h.shape.len() == 1 { "" } else { "s" },
                    RAYS_COLUMNS.join(",")
                ))
            }
        };
        let data_bytes = rows
            .checked_mul(IN_ROW as u64)
            .ok_or_else(|| format!("{name}: header field shape: {shape_s} is too large"))?;
        let reader = NpyReader {
            file,
            name,
            shape: h.shape,
            rows,
            done: 0,
            buf: Vec::new(),
        };
        // A regular file's length is checked now, before anything is evaluated (a pipe's
        // as it is read).
        if let Ok(meta) = reader.file.metadata() {
            if meta.is_file() {
                let avail = meta.len().saturating_sub(prelude as u64 + header_len);
                if avail < data_bytes {
                    return Err(reader.truncated(avail));
                }
                if avail > data_bytes {
                    return Err(reader.extra(Some(avail - data_bytes)));
                }
            }
        }
        Ok(reader)
    }

    /// The number of rays the header promises.
    pub(crate) fn rows(&self) -> u64 {
        self.rows
    }

    /// The error for data that ends after `avail` bytes.
    fn truncated(&self, avail: u64) -> String {
        let whole = avail / IN_ROW as u64;
        format!(
            "{}: truncated data: the header (shape {}) promises {} rows, but the data ends at row {whole} ({whole} complete rows, {avail} of {} bytes)",
            self.name,
            shape_repr(&self.shape),
            self.rows,
            self.rows * IN_ROW as u64
        )
    }

    /// The error for data after the last row.
    fn extra(&self, bytes: Option<u64>) -> String {
        let what = match bytes {
            Some(1) => "1 byte of extra data".to_string(),
            Some(b) => format!("{b} bytes of extra data"),
            None => "extra data".to_string(),
        };
        format!(
            "{}: {what} after the {} rows the header promises (shape {})",
            self.name,
            self.rows,
            shape_repr(&self.shape)
        )
    }

    /// Reads up to `max` rays into `cols` (ox, oy, oz, dx, dy, dz, t); 0 after the last.
    pub(crate) fn next_chunk(&mut self, max: usize, cols: &mut [Vec<f32>; 7]) -> CliResult<usize> {
        let n = (max as u64).min(self.rows - self.done) as usize;
        if n == 0 {
            for c in cols.iter_mut() {
                c.clear();
            }
            let mut extra = [0u8; 1];
            let got = read_full(&mut self.file, &mut extra)
                .map_err(|e| format!("{}: cannot read: {e}", self.name))?;
            if got > 0 {
                return Err(self.extra(None));
            }
            return Ok(0);
        }
        self.buf.resize(n * IN_ROW, 0);
        let got = read_full(&mut self.file, &mut self.buf)
            .map_err(|e| format!("{}: cannot read: {e}", self.name))?;
        if got < self.buf.len() {
            return Err(self.truncated(self.done * IN_ROW as u64 + got as u64));
        }
        decode(&self.name, self.done, &self.buf, cols)?;
        self.done += n as u64;
        Ok(n)
    }
}

/// Decodes rows of 7 little-endian f32 (row `first` of the file first) into the columns,
/// in parallel, checking each value as the CSV reader does; the earliest bad row wins.
fn decode(name: &str, first: u64, bytes: &[u8], cols: &mut [Vec<f32>; 7]) -> CliResult<()> {
    let n = bytes.len() / IN_ROW;
    for c in cols.iter_mut() {
        c.clear();
        c.resize(n, 0.0);
    }
    let [ox, oy, oz, dx, dy, dz, t] = cols;
    let bad = (
        ox.par_chunks_mut(PAR_ROWS),
        oy.par_chunks_mut(PAR_ROWS),
        oz.par_chunks_mut(PAR_ROWS),
        dx.par_chunks_mut(PAR_ROWS),
        dy.par_chunks_mut(PAR_ROWS),
        dz.par_chunks_mut(PAR_ROWS),
        t.par_chunks_mut(PAR_ROWS),
        bytes.par_chunks(PAR_ROWS * IN_ROW),
    )
        .into_par_iter()
        .enumerate()
        .filter_map(|(b, (c0, c1, c2, c3, c4, c5, c6, src))| {
            let mut outs = [c0, c1, c2, c3, c4, c5, c6];
            for (i, row) in src.chunks_exact(IN_ROW).enumerate() {
                for (k, out) in outs.iter_mut().enumerate() {
                    let x = f32::from_le_bytes([
                        row[4 * k],
                        row[4 * k + 1],
                        row[4 * k + 2],
                        row[4 * k + 3],
                    ]);
                    if let Some(problem) = ray_field_problem(k, x) {
                        return Some(((b * PAR_ROWS + i) as u64, k, problem, x));
                    }
                    out[i] = x;
                }
            }
            None
        })
        .min_by_key(|e| e.0);
    match bad {
        Some((row, k, problem, x)) => Err(format!(
            "{name}: row {}: field {}: {problem}, got {x:?}",
            first + row,
            RAYS_COLUMNS[k]
        )),
        None => Ok(()),
    }
}

// ---------------------------------------------------------------------------------------
// Writing results

/// The header of an N×9 little-endian float32 array, version 1.0, [`OUT_HEADER_LEN`]
/// bytes whatever N.
fn out_header(rows: u64) -> Vec<u8> {
    let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({rows}, 9), }}");
    let mut h = Vec::with_capacity(OUT_HEADER_LEN);
    h.extend_from_slice(MAGIC);
    h.extend_from_slice(&[1, 0]);
    h.extend_from_slice(&((OUT_HEADER_LEN - 10) as u16).to_le_bytes());
    h.extend_from_slice(dict.as_bytes());
    h.resize(OUT_HEADER_LEN - 1, b' ');
    h.push(b'\n');
    debug_assert_eq!(h.len(), OUT_HEADER_LEN);
    h
}

/// A `.npy` results file being written: the header with a placeholder row count first,
/// rewritten by [`NpyWriter::finish`].
pub(crate) struct NpyWriter<'a> {
    file: &'a File,
    w: BufWriter<&'a File>,
    name: String,
    rows: u64,
    bytes: Vec<u8>,
}

impl<'a> NpyWriter<'a> {
    pub(crate) fn new(file: &'a File, name: String) -> CliResult<NpyWriter<'a>> {
        let mut w = BufWriter::with_capacity(1 << 20, file);
        w.write_all(&out_header(0))
            .map_err(|e| format!("{name}: cannot write: {e}"))?;
        Ok(NpyWriter {
            file,
            w,
            name,
            rows: 0,
            bytes: Vec::new(),
        })
    }

    /// Appends the rows of the nine output columns.
    pub(crate) fn write_chunk(&mut self, cols: &[Vec<f32>; 9]) -> CliResult<()> {
        let n = cols[0].len();
        self.bytes.resize(n * OUT_ROW, 0);
        self.bytes
            .par_chunks_mut(PAR_ROWS * OUT_ROW)
            .enumerate()
            .for_each(|(b, dst)| {
                for (i, row) in dst.chunks_exact_mut(OUT_ROW).enumerate() {
                    let r = b * PAR_ROWS + i;
                    for (k, col) in cols.iter().enumerate() {
                        row[4 * k..4 * k + 4].copy_from_slice(&col[r].to_le_bytes());
                    }
                }
            });
        self.w
            .write_all(&self.bytes)
            .map_err(|e| format!("{}: cannot write: {e}", self.name))?;
        self.rows += n as u64;
        Ok(())
    }

    /// Flushes the data and writes the final header (same length) over the placeholder.
    pub(crate) fn finish(mut self) -> CliResult<()> {
        let werr = |e: io::Error| format!("{}: cannot write: {e}", self.name);
        self.w.flush().map_err(werr)?;
        let mut f = self.file;
        f.seek(SeekFrom::Start(0)).map_err(werr)?;
        f.write_all(&out_header(self.rows)).map_err(werr)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Header, String> {
        parse_header(s.as_bytes())
    }

    #[test]
    fn headers() {
        let want = || Header {
            descr: Py::Str("<f4".into()),
            fortran_order: false,
            shape: vec![5, 7],
        };
        for text in [
            "{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7), }          \n",
            "{\"shape\":(5,7),\"fortran_order\":False,\"descr\":\"<f4\"}",
            "{ 'descr' : '<f4' ,\n 'fortran_order' : False , 'shape' : ( 5L , 7 , ) }",
            "{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7)}",
        ] {
            assert_eq!(parse(text), Ok(want()), "{text}");
        }
        let h =
            parse("{'descr': [('x', '<f4'), ('y', '<f4')], 'fortran_order': True, 'shape': (3,)}")
                .unwrap();
        assert!(matches!(h.descr, Py::List(_)));
        assert!(h.fortran_order);
        assert_eq!(h.shape, vec![3]);
        assert_eq!(
            parse("{'descr': '<f4', 'fortran_order': False, 'shape': ()}")
                .unwrap()
                .shape,
            Vec::<u64>::new()
        );

        for (text, err) in [
            ("", "unexpected end"),
            ("[1, 2]", "expected a dict"),
            (
                "{'descr': '<f4', 'fortran_order': False}",
                "key 'shape' missing",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7), 'x': 1}",
                "unexpected key 'x'",
            ),
            (
                "{'descr': '<f4', 'fortran_order': 0, 'shape': (5, 7)}",
                "field fortran_order",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (5)}",
                "field shape",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (-5, 7)}",
                "field shape",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (5.0, 7)}",
                "expected an integer",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7)",
                "expected ',' or '}'",
            ),
            ("{'descr' '<f4'}", "expected ':'"),
            (
                "{'descr': '<f4', 'fortran_order': false, 'shape': (5, 7)}",
                "unknown name \"false\"",
            ),
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (5, 7)} x",
                "after the dict",
            ),
            ("{'descr': '<f4', 'descr': '<f4'}", "given twice"),
            (
                "{'descr': 1, 'fortran_order': False, 'shape': (5, 7)}",
                "field descr",
            ),
            (
                "{'shape': (99999999999999999999999999999999999999999, 7)}",
                "too large",
            ),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(err), "{text}: {e}");
        }
        let deep = "[".repeat(10_000);
        assert!(parse(&deep).unwrap_err().contains("nested too deeply"));
    }

    #[test]
    fn dtypes() {
        assert!(is_f32_le("<f4"));
        assert!(!is_f32_le(">f4"));
        assert!(!is_f32_le("<f8"));
        assert_eq!(describe_dtype("<f8"), "little-endian float64");
        assert_eq!(describe_dtype(">f4"), "big-endian float32");
        assert_eq!(describe_dtype("|u1"), "uint8");
        assert_eq!(describe_dtype("|b1"), "bool");
        assert_eq!(describe_dtype("<U3"), "unicode string");
        assert_eq!(describe_dtype("xyz"), "unknown type");
        assert_eq!(describe_dtype(""), "unknown type");
    }

    #[test]
    fn output_header() {
        for n in [0, 1, 313, u64::MAX] {
            let h = out_header(n);
            assert_eq!(h.len(), OUT_HEADER_LEN);
            let text = &h[10..];
            let parsed = parse_header(text).unwrap();
            assert_eq!(parsed.shape, vec![n, 9]);
            assert_eq!(parsed.descr, Py::Str("<f4".into()));
            assert_eq!(*h.last().unwrap(), b'\n');
        }
    }
}
