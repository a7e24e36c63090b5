//! cpfg's file functions in statements (issue 46 item 10): `fopen(name, mode)`,
//! `fscanf(file, format, &x, …)`, `fprintf`, `fflush` and `fclose`, as cpfg's
//! interpreter runs them (vlab `cpfg/generate.c` and `cpfg/userfiles.cpp`, Mech2004).
//!
//! - **Handles.** cpfg keeps 25 file slots and hands out their indices as a stack:
//!   the first `fopen` returns 24, the next 23, and a closed slot is the next one given
//!   out again. A file that cannot be opened (or a 26th open file) gives −1.
//! - **Reading.** sylva never opens files while deriving: the files a model's
//!   `fopen(…, "r")` calls name (string literals) are read beforehand, from inside the
//!   model folder only, within `input.max_bytes` (the pipeline, with the same
//!   confinement as every side file; [`file_reads`] finds them). A name the folder does
//!   not hold opens as −1, as in cpfg.
//! - **`fscanf`** reads with C's rules for the conversions cpfg's models can use: cpfg
//!   passes the address of its 8-byte (double) variable straight to C's `fscanf`, so
//!   `%lf`, `%le`, `%lg` (and `E G F a A`) read a number into the variable; `%f` (no
//!   `l`) stores a 4-byte float into the low half of the double, which on every
//!   platform cpfg runs on (little-endian) leaves a meaningless value: sylva does
//!   exactly that, and the pipeline warns. Suppressed conversions (`%*f`, `%*d`,
//!   `%*s`, `%*c`), `%%`, white space (any amount, none included) and literal
//!   characters work as in C; a field width is honoured. Other conversions (`%d`,
//!   `%s`, `%c`, `%[`, `%n` assigned to a variable: C would write an integer or bytes
//!   into the double) are an `unsupported:` error when the statement is compiled. The
//!   value is the number of variables assigned, or −1 (EOF) when the input ends before
//!   the first conversion.
//! - **Writing** (`"w"`, `"a"`): the handle is given out as cpfg does, and what
//!   `fprintf` writes is discarded (sylva writes no files; the pipeline warns).

use std::collections::HashMap;
use std::sync::Arc;

/// The number of file slots cpfg has (`MAXFILES`).
pub const MAX_FILES: usize = 25;

/// The contents of the files a model reads, by the name its `fopen` calls write.
pub type DataFiles = HashMap<String, Arc<[u8]>>;

/// One open file.
#[derive(Debug, Clone)]
enum Slot {
    /// Open for reading: the contents and the read position.
    Read { data: Arc<[u8]>, pos: usize },
    /// Open for writing: output is discarded.
    Write,
}

/// cpfg's file slots as a model's statements use them.
#[derive(Debug, Clone)]
pub struct OpenFiles {
    slots: Vec<Option<Slot>>,
    /// Free slot indices; the last is given out next (cpfg's `fix` stack).
    free: Vec<usize>,
}

impl Default for OpenFiles {
    fn default() -> Self {
        OpenFiles { slots: vec![None; MAX_FILES], free: (0..MAX_FILES).collect() }
    }
}

/// The slot index a handle value names, when it is one of the 25.
fn index(h: f64) -> Option<usize> {
    let i = h as i64; // C's (int) truncation
    (0..MAX_FILES as i64).contains(&i).then_some(i as usize)
}

impl OpenFiles {
    /// `fopen(name, mode)`: a handle (24, 23, … as cpfg gives them out), or −1 when the
    /// file cannot be opened (`data` is `None`: the model folder does not hold it) or
    /// all 25 slots are in use.
    pub fn open(&mut self, data: Option<Arc<[u8]>>, mode: &str) -> f64 {
        let slot = if mode.starts_with('r') {
            match data {
                Some(data) => Slot::Read { data, pos: 0 },
                None => return -1.0,
            }
        } else {
            Slot::Write
        };
        match self.free.pop() {
            Some(i) => {
                self.slots[i] = Some(slot);
                i as f64
            }
            None => -1.0,
        }
    }

    /// `fclose(h)`: 0, as cpfg (a handle that is not a slot is returned unchanged).
    pub fn close(&mut self, h: f64) -> f64 {
        let Some(i) = index(h) else { return h };
        if self.slots[i].take().is_some() {
            self.free.push(i);
        }
        0.0
    }

    /// `fflush(h)`: cpfg's value, the handle's index (a handle that is not a slot is
    /// returned unchanged).
    pub fn flush(&self, h: f64) -> f64 {
        index(h).map_or(h, |i| i as f64)
    }

    /// `fscanf(h, format, …)` with `old` the current values of the variables given:
    /// `Ok((value, new values))`, or `Err` with the reason when `h` is not a file open
    /// for reading (cpfg prints a message and its value is undefined).
    pub fn scan(&mut self, h: f64, format: &str, old: &[f64]) -> Result<(f64, Vec<f64>), &'static str> {
        let slot = index(h).and_then(|i| self.slots[i].as_mut());
        match slot {
            None => Err("fscanf of a file that is not open (fopen gave -1, or it was closed)"),
            // C's fscanf on a stream open for writing fails at once: EOF.
            Some(Slot::Write) => Ok((-1.0, old.to_vec())),
            Some(Slot::Read { data, pos }) => {
                let mut vals = old.to_vec();
                let v = scan(data, pos, format, &mut vals);
                Ok((v, vals))
            }
        }
    }
}

/// One directive of an `fscanf` format.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Directive {
    /// White space: skips any white space.
    Space,
    /// A character that must come next (`%%` is `Literal(b'%')`, after white space).
    Literal(u8, bool),
    /// A conversion.
    Conv { assign: bool, width: Option<usize>, kind: Conv },
}

/// What a conversion reads.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Conv {
    /// `%lf` and kin: a double.
    Double,
    /// `%f` and kin: a float, stored into the low half of cpfg's double.
    Float,
    /// `%d %i %u %x %o` (suppressed only): an integer.
    Int,
    /// `%s` (suppressed only): a run of non-white characters.
    Word,
    /// `%c` (suppressed only): characters, white space included.
    Chars,
}

/// Parses an `fscanf` format: the directives, or what is unsupported.
fn directives(format: &str) -> Result<Vec<Directive>, String> {
    let b = format.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            while i < b.len() && b[i].is_ascii_whitespace() {
                i += 1;
            }
            out.push(Directive::Space);
            continue;
        }
        if c != b'%' {
            out.push(Directive::Literal(c, false));
            i += 1;
            continue;
        }
        let start = i;
        i += 1;
        if b.get(i) == Some(&b'%') {
            out.push(Directive::Literal(b'%', true));
            i += 1;
            continue;
        }
        let assign = b.get(i) != Some(&b'*');
        if !assign {
            i += 1;
        }
        let w0 = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        let width = if i > w0 { format[w0..i].parse::<usize>().ok().filter(|&w| w > 0) } else { None };
        let m0 = i;
        while i < b.len() && matches!(b[i], b'l' | b'h' | b'L' | b'q' | b'j' | b'z' | b't') {
            i += 1;
        }
        let modifier = &format[m0..i];
        let Some(&conv) = b.get(i) else {
            return Err(format!("the format ends inside the conversion `{}`", &format[start..]));
        };
        i += 1;
        let text = &format[start..i];
        let kind = match (conv, modifier) {
            (b'f' | b'e' | b'g' | b'E' | b'G' | b'F' | b'a' | b'A', "l") => Conv::Double,
            (b'f' | b'e' | b'g' | b'E' | b'G' | b'F' | b'a' | b'A', "") => Conv::Float,
            (b'd' | b'i' | b'u' | b'x' | b'X' | b'o', _) if !assign => Conv::Int,
            (b's', "") if !assign => Conv::Word,
            (b'c', "") if !assign => Conv::Chars,
            _ => {
                return Err(format!(
                    "the conversion `{text}` (cpfg hands C's fscanf the address of an 8-byte double: only \
                     `%lf`, `%le`, `%lg` read a number into a variable; `%f` stores a float into half of it; \
                     suppressed `%*d`, `%*s`, `%*c` skip input)"
                ))
            }
        };
        out.push(Directive::Conv { assign, width, kind });
    }
    Ok(out)
}

/// How many variables the format assigns, or what in it is unsupported (an
/// `unsupported:` error when the statement is compiled).
pub fn check_format(format: &str) -> Result<usize, String> {
    Ok(directives(format)?.iter().filter(|d| matches!(d, Directive::Conv { assign: true, .. })).count())
}

/// Whether the format stores a float into a double (`%f` without `l`), which cpfg
/// does and which leaves a meaningless value.
pub fn stores_floats(format: &str) -> bool {
    directives(format)
        .is_ok_and(|d| d.iter().any(|d| matches!(d, Directive::Conv { assign: true, kind: Conv::Float, .. })))
}

/// C's `fscanf` over `data` from `*pos`: assigns `vals` in order, returns the count
/// assigned or −1 when the input ended before the first conversion.
fn scan(data: &[u8], pos: &mut usize, format: &str, vals: &mut [f64]) -> f64 {
    let Ok(dirs) = directives(format) else { return 0.0 };
    let mut assigned = 0usize;
    let mut converted = false;
    let skip_ws = |pos: &mut usize| {
        while *pos < data.len() && data[*pos].is_ascii_whitespace() {
            *pos += 1;
        }
    };
    let eof = |converted: bool, assigned: usize| if converted { assigned as f64 } else { -1.0 };
    for d in dirs {
        match d {
            Directive::Space => skip_ws(pos),
            Directive::Literal(c, percent) => {
                if percent {
                    skip_ws(pos);
                }
                match data.get(*pos) {
                    None => return eof(converted, assigned),
                    Some(&x) if x == c => *pos += 1,
                    Some(_) => return assigned as f64,
                }
            }
            Directive::Conv { assign, width, kind } => {
                if kind != Conv::Chars {
                    skip_ws(pos);
                }
                if *pos >= data.len() {
                    return eof(converted, assigned);
                }
                let limit = width.map_or(data.len(), |w| (*pos + w).min(data.len()));
                let field = &data[*pos..limit];
                let n = match kind {
                    Conv::Double | Conv::Float => number_len(field),
                    Conv::Int => int_len(field),
                    Conv::Word => field.iter().take_while(|c| !c.is_ascii_whitespace()).count(),
                    Conv::Chars => field.len().min(width.unwrap_or(1)),
                };
                if n == 0 {
                    return assigned as f64;
                }
                let text = std::str::from_utf8(&field[..n]).unwrap_or("0");
                *pos += n;
                converted = true;
                if assign {
                    let Some(slot) = vals.get_mut(assigned) else { continue };
                    *slot = match kind {
                        Conv::Double => text.parse::<f64>().unwrap_or(0.0),
                        _ => {
                            // cpfg: a 4-byte float written over the low half of the double.
                            let f = text.parse::<f32>().unwrap_or(0.0).to_bits() as u64;
                            f64::from_bits((slot.to_bits() & 0xFFFF_FFFF_0000_0000) | f)
                        }
                    };
                    assigned += 1;
                }
            }
        }
    }
    assigned as f64
}

/// The length of the decimal number at the start of `s` (sign, digits with one point,
/// an exponent when digits follow it), 0 when there is none.
fn number_len(s: &[u8]) -> usize {
    let mut i = usize::from(matches!(s.first(), Some(b'+' | b'-')));
    let mut digits = 0;
    while i < s.len() && s[i].is_ascii_digit() {
        i += 1;
        digits += 1;
    }
    if i < s.len() && s[i] == b'.' {
        i += 1;
        while i < s.len() && s[i].is_ascii_digit() {
            i += 1;
            digits += 1;
        }
    }
    if digits == 0 {
        return 0;
    }
    if i < s.len() && matches!(s[i], b'e' | b'E') {
        let mut j = i + 1;
        if j < s.len() && matches!(s[j], b'+' | b'-') {
            j += 1;
        }
        let e0 = j;
        while j < s.len() && s[j].is_ascii_digit() {
            j += 1;
        }
        if j > e0 {
            i = j;
        }
    }
    i
}

/// The length of the integer at the start of `s` (sign, digits), 0 when there is none.
fn int_len(s: &[u8]) -> usize {
    let i = usize::from(matches!(s.first(), Some(b'+' | b'-')));
    let n = s[i..].iter().take_while(|c| c.is_ascii_digit()).count();
    if n == 0 {
        0
    } else {
        i + n
    }
}

/// A file that a model's statements open, found in its text: `fopen("name", "mode")`.
#[derive(Debug, Clone, PartialEq)]
pub struct FileUse {
    /// The name as written.
    pub name: String,
    /// The mode as written (`r`, `w`, `a`, …).
    pub mode: String,
    /// Byte offset of the `fopen` in the text.
    pub at: usize,
}

impl FileUse {
    /// Whether the file is opened for reading.
    pub fn reads(&self) -> bool {
        self.mode.starts_with('r')
    }
}

/// The `fopen` calls with string-literal arguments in `text` (a model's preprocessed
/// L-system), in order.
pub fn file_reads(text: &str) -> Vec<FileUse> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = text[from..].find("fopen") {
        let at = from + k;
        from = at + 5;
        if at > 0 && (b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_') {
            continue;
        }
        let mut i = from;
        let ws = |i: &mut usize| {
            while *i < b.len() && b[*i].is_ascii_whitespace() {
                *i += 1;
            }
        };
        let string = |i: &mut usize| -> Option<String> {
            ws(i);
            if b.get(*i) != Some(&b'"') {
                return None;
            }
            let s = *i + 1;
            let e = s + text[s..].find('"')?;
            *i = e + 1;
            Some(unescape(&text[s..e]))
        };
        ws(&mut i);
        if b.get(i) != Some(&b'(') {
            continue;
        }
        i += 1;
        let Some(name) = string(&mut i) else { continue };
        ws(&mut i);
        if b.get(i) != Some(&b',') {
            continue;
        }
        i += 1;
        let Some(mode) = string(&mut i) else { continue };
        out.push(FileUse { name, mode, at });
    }
    out
}

/// The offsets of the `fscanf` calls in `text` whose format stores a float into a
/// double (`%f` without `l`; [`stores_floats`]), for the pipeline's warning.
pub fn float_stores(text: &str) -> Vec<usize> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = text[from..].find("fscanf") {
        let at = from + k;
        from = at + 6;
        let rest = &text[from..];
        let Some(q) = rest.find('"') else { break };
        if rest[..q].contains(';') {
            continue;
        }
        let Some(e) = rest[q + 1..].find('"') else { break };
        if stores_floats(&unescape(&rest[q + 1..q + 1 + e])) {
            out.push(at);
        }
    }
    out
}

/// C's escapes in a string literal (`\n \t \\ \"`; others keep the character).
pub fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut it = s.chars();
    while let Some(c) = it.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match it.next() {
            Some('n') => out.push('\n'),
            Some('t') => out.push('\t'),
            Some('r') => out.push('\r'),
            Some(o) => out.push(o),
            None => out.push('\\'),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open(text: &str) -> (OpenFiles, f64) {
        let mut f = OpenFiles::default();
        let h = f.open(Some(Arc::from(text.as_bytes())), "r");
        (f, h)
    }

    #[test]
    fn handles_are_given_out_as_cpfg_does() {
        let mut f = OpenFiles::default();
        assert_eq!(f.open(Some(Arc::from(&b""[..])), "r"), 24.0);
        assert_eq!(f.open(None, "w"), 23.0);
        assert_eq!(f.open(None, "r"), -1.0, "a file the folder does not hold");
        assert_eq!(f.close(24.0), 0.0);
        assert_eq!(f.open(None, "a"), 24.0, "the closed slot is given out again");
        for _ in 0..23 {
            assert!(f.open(None, "w") >= 0.0);
        }
        assert_eq!(f.open(None, "w"), -1.0, "25 slots");
        assert_eq!(f.flush(3.0), 3.0);
    }

    #[test]
    fn fscanf_reads_doubles_and_counts() {
        let (mut f, h) = open("  1.5 -2e1\n3 x 7");
        let (n, v) = f.scan(h, "%lf %lf", &[0.0, 0.0]).unwrap();
        assert_eq!((n, v), (2.0, vec![1.5, -20.0]));
        let (n, v) = f.scan(h, "%lf", &[9.0]).unwrap();
        assert_eq!((n, v), (1.0, vec![3.0]));
        // A matching failure assigns nothing and leaves the input there.
        let (n, v) = f.scan(h, "%lf", &[9.0]).unwrap();
        assert_eq!((n, v), (0.0, vec![9.0]));
        let (n, _) = f.scan(h, " x%*d", &[]).unwrap();
        assert_eq!(n, 0.0);
        // End of input before the first conversion: EOF.
        assert_eq!(f.scan(h, "%lf", &[1.0]).unwrap(), (-1.0, vec![1.0]));
        assert!(f.scan(5.0, "%lf", &[0.0]).is_err());
    }

    #[test]
    fn width_literals_and_suppression() {
        let (mut f, h) = open("12345,6;%7 word next");
        let (n, v) = f.scan(h, "%2lf%*1d%lf,%lf;%%%lf %*s", &[0.0; 4]).unwrap();
        assert_eq!(n, 4.0);
        assert_eq!(v, vec![12.0, 45.0, 6.0, 7.0]);
    }

    #[test]
    fn percent_f_stores_a_float_into_half_a_double() {
        let (mut f, h) = open("0.5");
        let old = 2.0f64;
        let (_, v) = f.scan(h, "%f", &[old]).unwrap();
        let want = f64::from_bits((old.to_bits() & 0xFFFF_FFFF_0000_0000) | 0.5f32.to_bits() as u64);
        assert_eq!(v[0].to_bits(), want.to_bits());
        assert!(stores_floats("%f") && !stores_floats("%lf %*f"));
        assert_eq!(float_stores("a = fscanf(f, \"%lf\", &x); b = fscanf(g, \" %f\", &y);"), vec![30]);
    }

    #[test]
    fn unsupported_conversions_are_named() {
        assert_eq!(check_format("%lf %*d %le%%"), Ok(2));
        for bad in ["%d", "%s", "%c", "%[a]", "%Lf", "%n", "%lf %"] {
            assert!(check_format(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn file_reads_are_found() {
        let t =
            "Start: { f = fopen(\"data.txt\", \"r\"); g=fopen( \"o.txt\" ,\"w\"); myfopen(\"x\",\"r\"); }";
        let r = file_reads(t);
        assert_eq!(r.len(), 2);
        assert_eq!((r[0].name.as_str(), r[0].reads()), ("data.txt", true));
        assert_eq!((r[1].name.as_str(), r[1].reads()), ("o.txt", false));
    }
}
