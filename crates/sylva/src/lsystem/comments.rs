//! Comment removal shared by the L-system preprocessor and cpfg's data-file readers:
//! `/* … */` and `//` comments become spaces with every byte offset kept, as the C
//! preprocessor cpfg runs does (Mech2004). A leaf module, so the readers of view files
//! need not depend on the preprocessor (which depends on the expression compiler).

/// Which text [`blank_comments`] reads: what it leaves alone besides newlines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CommentStyle {
    /// L-system files: string literals (`"…"` up to the line's end) are not searched for
    /// comments, and the non-ASCII bytes of comments are copied unchanged.
    Lsystem,
    /// cpfg's data files (view files): every byte of a comment becomes a space.
    Data,
}

/// Replaces `/* … */` and `//` comments by spaces (newlines kept), so every byte offset
/// stays the same: the C preprocessor's comment removal, which cpfg runs on L-system
/// and view files (Mech2004).
pub(crate) fn blank_comments(s: &str, style: CommentStyle) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let blank = |c: u8| {
        if c == b'\n' {
            b'\n'
        } else if c < 0x80 || style == CommentStyle::Data {
            b' '
        } else {
            c
        }
    };
    while i < b.len() {
        if b[i] == b'/' && i + 1 < b.len() && b[i + 1] == b'*' {
            out.extend_from_slice(b"  ");
            i += 2;
            while i < b.len() && !(b[i] == b'*' && i + 1 < b.len() && b[i + 1] == b'/') {
                out.push(blank(b[i]));
                i += 1;
            }
            if i < b.len() {
                out.extend_from_slice(b"  ");
                i += 2;
            }
        } else if b[i] == b'/' && i + 1 < b.len() && b[i + 1] == b'/' {
            while i < b.len() && b[i] != b'\n' {
                out.push(blank(b[i]));
                i += 1;
            }
        } else if b[i] == b'"' && style == CommentStyle::Lsystem {
            out.push(b[i]);
            i += 1;
            while i < b.len() && b[i] != b'"' && b[i] != b'\n' {
                out.push(b[i]);
                i += 1;
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    // Comments start and end on ASCII bytes and their non-ASCII bytes were either all
    // copied or all blanked, so no multi-byte character was split.
    String::from_utf8(out).unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
}
