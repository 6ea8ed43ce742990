//! Input echoed in messages, escaped and cut short: a message quoted a 100 kB key or line of a hostile file in
//! full, and a mutated `.hdr` put NUL, ^B, ^P, ^\\ and DEL from its FORMAT line straight onto the user's terminal
//! (a crafted file could have sent escape sequences). Every control character a message carries is written as
//! its escape (`\u{1b}`, `\0`, `\t`, as `{:?}` writes it); a message's own line breaks are kept.

/// The longest run of input a message quotes whole when it quotes it on purpose ([`excerpt`]), in characters.
pub const MAX_EXCERPT_CHARS: usize = 80;
/// The longest word (a run without white space) [`shorten`] leaves whole, in characters: longer than any file
/// path a message names in practice, far shorter than the 5–100 kB strings hostile input put in messages.
pub const MAX_WORD_CHARS: usize = 256;
/// The longest line of a message [`shorten`] leaves whole, in characters (a parser's message may show the line
/// of the file it stopped in).
pub const MAX_LINE_CHARS: usize = 1000;

/// `text` with its control characters escaped when it has at most [`MAX_EXCERPT_CHARS`] characters; else its
/// start and end around an ellipsis, and its length.
pub fn excerpt(text: &str) -> String {
    cut(&escape_controls(text, false), MAX_EXCERPT_CHARS)
}

/// `text` in double quotes as `{:?}` writes a string (control characters, quotes and backslashes escaped), cut
/// as [`excerpt`] cuts: for input quoted in a message whatever bytes it holds (`unsupported FORMAT "32-bi\0"`).
pub fn quote(text: &str) -> String {
    let escaped = format!("{text:?}");
    let inner = &escaped[1..escaped.len() - 1];
    format!("\"{}\"", cut(&escape_controls(inner, false), MAX_EXCERPT_CHARS))
}

/// Whether `c` may reach a terminal as it is: not a control character (C0, DEL, C1) and not one of the
/// invisible bidirectional controls that reorder what a terminal shows (U+200E/F, U+202A–E, U+2066–9).
fn printable(c: char) -> bool {
    !c.is_control() && !matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// `text` with every character that is not [`printable`] written as its escape (`\u{1b}`, `\0`, `\t`, `\r`),
/// line breaks too unless `keep_newlines`.
pub fn escape_controls(text: &str, keep_newlines: bool) -> String {
    if text.chars().all(|c| printable(c) || (keep_newlines && c == '\n')) {
        return text.to_string();
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        if printable(c) || (keep_newlines && c == '\n') {
            out.push(c);
        } else {
            // `{:?}`'s escape (`\0`, `\t`, `\u{1b}`); the code point where it would leave the character as it is.
            let e: String = c.escape_debug().collect();
            if e.chars().count() == 1 {
                out.extend(c.escape_unicode());
            } else {
                out.push_str(&e);
            }
        }
    }
    out
}

/// `text` itself up to `max` characters; else its first 5/8 and last 1/4 of `max` characters (a file path keeps
/// its file name) and its length in bytes.
fn cut(text: &str, max: usize) -> String {
    let chars = text.chars().count();
    if chars <= max {
        return text.to_string();
    }
    let (head, tail) = (max * 5 / 8, max / 4);
    let at = |k: usize| text.char_indices().nth(k).map_or(text.len(), |(i, _)| i);
    format!("{}…{} ({} bytes in all)", &text[..at(head)], &text[at(chars - tail)..], text.len())
}

/// A message with its control characters escaped (its line breaks kept: [`escape_controls`]), every word longer
/// than [`MAX_WORD_CHARS`] cut as [`excerpt`] cuts, then every line longer than [`MAX_LINE_CHARS`]. Applied to
/// every message that can carry the user's input: the demo's final error and its usage errors, the loaders'
/// errors, the log's lines.
pub fn shorten(message: &str) -> String {
    let escaped = escape_controls(message, true);
    let message = escaped.as_str();
    let long_word = |w: &str| w.char_indices().nth(MAX_WORD_CHARS).is_some();
    if !message.split_whitespace().any(long_word)
        && !message.lines().any(|l| l.char_indices().nth(MAX_LINE_CHARS).is_some())
    {
        return message.to_string();
    }
    let mut out = String::with_capacity(message.len().min(4 * MAX_LINE_CHARS));
    for (k, line) in message.split('\n').enumerate() {
        if k > 0 {
            out.push('\n');
        }
        let mut words = String::new();
        let mut rest = line;
        while !rest.is_empty() {
            let split = rest.find(char::is_whitespace).unwrap_or(rest.len());
            let (word, tail) = rest.split_at(split);
            words.push_str(&cut(word, MAX_WORD_CHARS));
            let space_end = tail.find(|c: char| !c.is_whitespace()).unwrap_or(tail.len());
            words.push_str(&tail[..space_end]);
            rest = &tail[space_end..];
        }
        out.push_str(&cut(&words, MAX_LINE_CHARS));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_text_is_kept_and_long_text_cut() {
        assert_eq!(excerpt("Kd"), "Kd");
        let long = "k".repeat(100_000);
        let e = excerpt(&long);
        assert!(e.len() < 120 && e.ends_with("kkk (100000 bytes in all)") && e.contains("k…k"), "{e}");
        // A path keeps its file name.
        let path = format!("/{}/scene.toml", "d".repeat(100));
        assert!(excerpt(&path).contains("/scene.toml ("), "{}", excerpt(&path));
        // Multi-byte characters are cut on a character boundary.
        let e = excerpt(&"é".repeat(500));
        assert!(e.starts_with("éé") && e.contains("(1000 bytes in all)"), "{e}");
    }

    #[test]
    fn messages_keep_their_words_and_lose_the_bulk() {
        let m = "unknown field `colour`, expected `center`";
        assert_eq!(shorten(m), m);
        let key = "a".repeat(100_000);
        let m = format!("TOML parse error at line 1\nunknown field `{key}`, expected one of `camera`, `model`");
        let s = shorten(&m);
        assert!(s.len() < 400, "{} bytes: {s}", s.len());
        assert!(s.starts_with("TOML parse error at line 1\nunknown field `aaa"), "{s}");
        assert!(s.ends_with("expected one of `camera`, `model`"), "{s}");
        // A long line of short words (a parser showing the offending line).
        let line = "1 | ".to_string() + &"ab ".repeat(50_000);
        let s = shorten(&line);
        assert!(s.chars().count() < MAX_LINE_CHARS + 40, "{s}");
        // A long file path is no input to cut.
        let m = format!("/{}/scene.toml: file not found", "d/".repeat(60));
        assert_eq!(shorten(&m), m);
    }

    /// No control character of the input reaches the terminal: a mutated .hdr's FORMAT line carried NUL, ^B, ^P,
    /// ^\\ and DEL, and an escape sequence would have been obeyed.
    #[test]
    fn control_characters_are_escaped() {
        let hostile = "32-bi\0\u{2}\u{10}\u{1c}\u{7f}\u{1b}[2J\u{1b}]0;title\u{7}\r\u{9b}\u{202e}txt.exe";
        for s in [excerpt(hostile), quote(hostile), shorten(hostile), shorten(&format!("a\n{hostile}\nb"))] {
            assert!(!s.chars().any(|c| (c.is_control() && c != '\n') || c == '\u{202e}'), "{s:?}");
            assert!(s.contains("\\u{1b}[2J") && s.contains("\\0"), "{s}");
        }
        assert_eq!(quote("FORMAT\u{0}"), "\"FORMAT\\0\"");
        assert_eq!(quote("a\"b"), "\"a\\\"b\"");
        // Line breaks of a message stay; those inside a quoted value do not.
        assert_eq!(shorten("line 1\nline 2"), "line 1\nline 2");
        assert_eq!(excerpt("a\nb"), "a\\nb");
        // Other text is untouched.
        assert_eq!(excerpt("Überbrückung é ✓"), "Überbrückung é ✓");
        // Cut after escaping: the escapes count towards the length.
        assert!(excerpt(&"\u{1b}".repeat(1000)).contains("bytes in all"));
    }
}
