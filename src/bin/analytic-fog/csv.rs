//! Rays CSV in (`ox,oy,oz,dx,dy,dz,t`), results CSV out
//! (`tau_r,tau_g,tau_b,T_r,T_g,T_b,in_r,in_g,in_b`).

use crate::{ray_field_problem, CliResult, PAR_ROWS, RAYS_COLUMNS};
use rayon::prelude::*;
use std::io::{BufRead, Read};

/// The longest line accepted in a rays file (bytes, newline included).
const MAX_LINE: u64 = 64 * 1024;

// Rays CSV

/// One data row of the rays file: its bytes in the chunk buffer and its line number.
pub(crate) struct Row {
    start: usize,
    end: usize,
    line: u64,
}

/// Reads the rays file line by line into a chunk buffer.
pub(crate) struct RayReader<R> {
    inp: R,
    pub(crate) name: String,
    /// Lines read so far.
    line: u64,
    /// The first blank line not yet followed by a row (blank lines are allowed at the
    /// end of the file only).
    blank: Option<u64>,
    pub(crate) buf: Vec<u8>,
    /// Bytes read so far (for the progress report).
    pub(crate) bytes_read: u64,
}

impl<R: BufRead> RayReader<R> {
    pub(crate) fn new(inp: R, name: String) -> Self {
        RayReader {
            inp,
            name,
            line: 0,
            blank: None,
            buf: Vec::new(),
            bytes_read: 0,
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
        self.bytes_read += n as u64;
        if n as u64 == MAX_LINE && self.buf.last() != Some(&b'\n') {
            self.buf.truncate(before);
            return Err(format!(
                "{}:{}: line longer than {MAX_LINE} bytes",
                self.name, self.line
            ));
        }
        Ok(true)
    }

    pub(crate) fn read_header(&mut self) -> CliResult<()> {
        self.buf.clear();
        let expected = RAYS_COLUMNS.join(",");
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
        let bad = (0..RAYS_COLUMNS.len().max(cols.len()))
            .find(|&k| cols.get(k).copied() != RAYS_COLUMNS.get(k).copied());
        if let Some(k) = bad {
            let field = match RAYS_COLUMNS.get(k) {
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
    pub(crate) fn next_chunk(&mut self, max: usize) -> CliResult<Vec<Row>> {
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
    let n = RAYS_COLUMNS.len();
    if count < n {
        return Err(format!(
            "{name}:{line}: field {}: missing (the row has {count} fields, expected {n})",
            RAYS_COLUMNS[count],
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
        let field = RAYS_COLUMNS[k];
        let x: f32 = f.parse().map_err(|_| {
            format!(
                "{name}:{line}: field {field}: not a number: {}",
                quoted(&raw)
            )
        })?;
        if let Some(problem) = ray_field_problem(k, x) {
            return Err(format!(
                "{name}:{line}: field {field}: {problem}, got {}",
                quoted(&raw)
            ));
        }
        v[k] = x;
    }
    Ok(v)
}

/// Parses a chunk's rows in parallel; the error of the earliest bad line wins.
pub(crate) fn parse_rows(name: &str, buf: &[u8], rows: &[Row]) -> CliResult<Vec<[f32; 7]>> {
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

/// The output header line (without its newline).
pub(crate) fn out_header() -> String {
    crate::OUT_COLUMNS.join(",")
}

/// A chunk's output rows (the nine output columns) as CSV text, in blocks formatted in
/// parallel.
pub(crate) fn format_rows(output: &[Vec<f32>; 9]) -> Vec<Vec<u8>> {
    let n = output[0].len();
    (0..n.div_ceil(PAR_ROWS))
        .into_par_iter()
        .map(|b| {
            let mut s = Vec::with_capacity(PAR_ROWS * 96);
            let mut fbuf = zmij::Buffer::new();
            for r in b * PAR_ROWS..((b + 1) * PAR_ROWS).min(n) {
                for (k, col) in output.iter().enumerate() {
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

/// Writes `x` in the shortest decimal form that reads back as exactly `x` (zmij, the
/// formatter serde_json uses: `0.057505865`, `1.0`, `1.5e-30`); `inf` for +∞.
fn write_f32(s: &mut Vec<u8>, buf: &mut zmij::Buffer, x: f32) {
    s.extend_from_slice(buf.format(x).as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

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
