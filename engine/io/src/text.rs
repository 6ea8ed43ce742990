//! Input echoed in messages, cut short: a message quoted a 100 kB key or line of a hostile file in full.

/// The longest run of input a message quotes whole, in characters.
pub const MAX_EXCERPT_CHARS: usize = 80;
/// The longest line of a message, in characters (a parser's message may show the line of the file it stopped in).
pub const MAX_LINE_CHARS: usize = 400;

/// `text` when it has at most [`MAX_EXCERPT_CHARS`] characters; else its start, an ellipsis and its length.
pub fn excerpt(text: &str) -> String {
    cut(text, MAX_EXCERPT_CHARS)
}

fn cut(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        None => text.to_string(),
        Some(_) => {
            let keep = max * 3 / 4;
            let end = text.char_indices().nth(keep).map_or(text.len(), |(i, _)| i);
            format!("{}… ({} bytes in all)", &text[..end], text.len())
        }
    }
}

/// A message with every word (a run without white space) longer than [`MAX_EXCERPT_CHARS`] cut to an
/// [`excerpt`], then every line longer than [`MAX_LINE_CHARS`] cut. Applied to every message that can carry the
/// user's input: the demo's final error, the loaders' errors.
pub fn shorten(message: &str) -> String {
    let long_word = |w: &str| w.char_indices().nth(MAX_EXCERPT_CHARS).is_some();
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
            words.push_str(&excerpt(word));
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
        assert!(e.len() < 120 && e.ends_with("… (100000 bytes in all)"), "{e}");
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
        assert!(s.len() < 300, "{} bytes: {s}", s.len());
        assert!(s.starts_with("TOML parse error at line 1\nunknown field `aaa"), "{s}");
        assert!(s.ends_with("expected one of `camera`, `model`"), "{s}");
        // A long line of short words (a parser showing the offending line).
        let line = "1 | ".to_string() + &"ab ".repeat(50_000);
        let s = shorten(&line);
        assert!(s.chars().count() < MAX_LINE_CHARS + 40, "{s}");
    }
}
