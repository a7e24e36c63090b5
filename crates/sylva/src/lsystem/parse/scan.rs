//! Byte-level scanning shared by the parser: whitespace, module symbols (`@` two-letter
//! names), matching brackets, argument lists and top-level search outside brackets.

pub(super) fn skip_ws(s: &[u8], mut i: usize, end: usize) -> usize {
    while i < end && s[i].is_ascii_whitespace() {
        i += 1;
    }
    i
}

/// Two-letter `@` modules of cpfg (`@Ts`, `@Gs`, …); other `@X` are one letter.
const AT_TWO_LETTER: &[&str] = &[
    "Ts", "Tf", "Ti", "Td", "Tx", "Gs", "Gc", "Ge", "Gr", "Gt", "Di", "Dd", "Ds", "Dt", "Pa", "Pc", "Pd",
    "Pt", "Pm", "Ms", "Mb",
];

/// Reads one module name starting at byte `i`: a single character, `@X`/`@Xy`/`@#`, `?X`
/// (cpfg query and communication modules) or `~x` (named surface).
pub fn symbol_at(text: &str, i: usize, end: usize) -> (String, usize) {
    let s = text.as_bytes();
    let c = text[i..].chars().next().unwrap_or(' ');
    let mut j = i + c.len_utf8();
    match c {
        // `@#` selects a generalized cylinder's contour (issue 26).
        '@' if j < end && s[j] == b'#' => j += 1,
        '@' if j < end && s[j].is_ascii_alphabetic() => {
            j += 1;
            if j < end && j < s.len() && s[j].is_ascii_alphabetic() {
                let two = &text[j - 1..(j + 1).min(text.len())];
                if AT_TWO_LETTER.contains(&two) {
                    j += 1;
                }
            }
        }
        '?' if j < end && s[j].is_ascii_uppercase() => j += 1,
        '~' if j < end && s[j].is_ascii_alphanumeric() => j += 1,
        _ => {}
    }
    (text[i..j].to_string(), j)
}

/// Index of the `close` matching the `open` at `at`, within `end`.
pub(super) fn matching(s: &[u8], at: usize, end: usize, open: u8, close: u8) -> Option<usize> {
    let mut depth = 0usize;
    let mut k = at;
    while k < end.min(s.len()) {
        let c = s[k];
        if c == b'"' {
            k += 1;
            while k < end && s[k] != b'"' {
                k += 1;
            }
        } else if c == open {
            depth += 1;
        } else if c == close {
            depth = depth.saturating_sub(1);
            if depth == 0 {
                return Some(k);
            }
        }
        k += 1;
    }
    None
}

/// Splits `s[start..end]` at top-level commas.
pub(super) fn split_args(s: &[u8], start: usize, end: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut a = start;
    for (k, &c) in s.iter().enumerate().take(end).skip(start) {
        match c {
            b'(' | b'[' => depth += 1,
            b')' | b']' => depth -= 1,
            b',' if depth == 0 => {
                out.push((a, k));
                a = k + 1;
            }
            _ => {}
        }
    }
    out.push((a, end));
    out
}

/// Offset of the first `c` outside parentheses and braces.
pub(super) fn top_level_find(text: &str, c: u8) -> Option<usize> {
    let mut depth = 0i32;
    let mut braces = 0i32;
    for (k, &b) in text.as_bytes().iter().enumerate() {
        match b {
            b'(' => depth += 1,
            b')' => depth -= 1,
            b'{' if c != b'{' => braces += 1,
            b'}' if c != b'{' => braces -= 1,
            _ if b == c && depth == 0 && braces == 0 => return Some(k),
            _ => {}
        }
    }
    None
}

/// Offset of the first `pat` outside parentheses and braces.
pub(super) fn top_level_find_str(text: &str, pat: &str) -> Option<usize> {
    let b = text.as_bytes();
    let p = pat.as_bytes();
    let mut depth = 0i32;
    let mut k = 0;
    while k + p.len() <= b.len() {
        match b[k] {
            b'(' | b'{' => depth += 1,
            b')' | b'}' => depth -= 1,
            _ if depth <= 0 && &b[k..k + p.len()] == p => return Some(k),
            _ => {}
        }
        k += 1;
    }
    None
}
