//! One typed parser for `name:key=value,...` specs (every technique's options, `--brdf`), driven by
//! a schema: per key its type, range, default and help. Unknown keys, bad values and out-of-range
//! values are errors that name the key and what it accepts (Mitsuba's unqueried-property rule). The
//! same schema generates the `--help` text and the option tables of docs/techniques/.

use engine_io::excerpt;
use std::fmt::Write as _;

/// What values a key takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// An integer in `min..=max`.
    Int { min: i64, max: i64 },
    /// A finite number in `[min, max]`, or `(min, max]` / `[min, max)` / `(min, max)` where open.
    Float { min: f64, max: f64, min_open: bool, max_open: bool },
    /// One of the listed words.
    Choice(&'static [&'static str]),
    /// A non-zero direction `x/y/z`, normalized.
    Direction,
}

impl Kind {
    pub const fn closed(min: f64, max: f64) -> Self {
        Kind::Float { min, max, min_open: false, max_open: false }
    }

    /// The accepted values, as written in errors and help: `1..=32`, `(0, 1)`, `map|ratio|sg`.
    pub fn accepted(&self) -> String {
        match *self {
            Kind::Int { min, max } => format!("an integer in {min}..={max}"),
            Kind::Float { min, max, min_open, max_open } => {
                let lo = if min_open { '(' } else { '[' };
                let hi = if max_open || max.is_infinite() { ')' } else { ']' };
                let max = if max.is_infinite() { "∞".to_string() } else { format!("{max}") };
                format!("a number in {lo}{min}, {max}{hi}")
            }
            Kind::Choice(words) => format!("one of {}", words.join(", ")),
            Kind::Direction => "a non-zero direction x/y/z".to_string(),
        }
    }
}

/// One key of a schema.
#[derive(Clone, Copy, Debug)]
pub struct OptionSpec {
    pub key: &'static str,
    /// Other spellings accepted for the key (e.g. `k` for `K`).
    pub aliases: &'static [&'static str],
    pub kind: Kind,
    /// The default as written on the command line; `None`: the key is unset unless given (the
    /// caller keeps its own value, e.g. `--brdf` keeps the material's).
    pub default: Option<&'static str>,
    pub help: &'static str,
}

/// A parsed value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    Int(i64),
    Float(f64),
    Choice(&'static str),
    Direction([f64; 3]),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Int(x) => write!(f, "{x}"),
            Value::Float(x) => write!(f, "{x}"),
            Value::Choice(w) => write!(f, "{w}"),
            Value::Direction([x, y, z]) => write!(f, "{x}/{y}/{z}"),
        }
    }
}

/// A spec that does not parse: names the key and what it accepts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct OptionError(pub String);

/// The values of one spec, defaults filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    values: Vec<(&'static str, Value, bool)>,
}

/// `key=value` pairs as written, in order.
pub type Pairs = Vec<(String, String)>;

/// Split `name[:key=value,key=value...]` into its name and its `key=value` pairs.
pub fn split_spec(spec: &str) -> Result<(&str, Pairs), OptionError> {
    let (name, rest) = spec.split_once(':').unwrap_or((spec, ""));
    let mut pairs = Vec::new();
    for part in rest.split(',').filter(|p| !p.trim().is_empty()) {
        let (k, v) = part
            .split_once('=')
            .ok_or_else(|| OptionError(format!("'{}': option '{}' is not key=value", excerpt(spec), excerpt(part))))?;
        pairs.push((k.trim().to_string(), v.trim().to_string()));
    }
    Ok((name.trim(), pairs))
}

fn parse_value(kind: Kind, v: &str) -> Option<Value> {
    match kind {
        Kind::Int { min, max } => v.parse::<i64>().ok().filter(|x| (min..=max).contains(x)).map(Value::Int),
        Kind::Float { min, max, min_open, max_open } => v
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .filter(|&x| if min_open { x > min } else { x >= min })
            .filter(|&x| if max_open { x < max } else { x <= max })
            .map(Value::Float),
        Kind::Choice(words) => words.iter().find(|w| **w == v).map(|w| Value::Choice(w)),
        Kind::Direction => {
            let c: Vec<f64> = v.split('/').map(|x| x.trim().parse::<f64>()).collect::<Result<_, _>>().ok()?;
            let len = c.iter().map(|x| x * x).sum::<f64>().sqrt();
            (c.len() == 3 && c.iter().all(|x| x.is_finite()) && len > 0.0)
                .then(|| Value::Direction([c[0] / len, c[1] / len, c[2] / len]))
        }
    }
}

/// Parse `pairs` against `schema`. `what` names the thing in errors (`isg`, `--brdf 'cook-torrance'`).
pub fn parse(what: &str, schema: &[OptionSpec], pairs: &[(String, String)]) -> Result<Options, OptionError> {
    let mut values = Vec::with_capacity(schema.len());
    for s in schema {
        if let Some(d) = s.default {
            let v = parse_value(s.kind, d)
                .ok_or_else(|| OptionError(format!("internal: {what} option {}: bad default '{d}'", s.key)))?;
            values.push((s.key, v, false));
        }
    }
    for (k, v) in pairs {
        let Some(s) = schema.iter().find(|s| s.key == k || s.aliases.contains(&k.as_str())) else {
            let keys: Vec<&str> = schema.iter().map(|s| s.key).collect();
            return Err(OptionError(if keys.is_empty() {
                format!("{what} has no options (got '{}')", excerpt(k))
            } else {
                format!("{what} has no option '{}' (options: {})", excerpt(k), keys.join(", "))
            }));
        };
        // A key given twice (also through an alias) has no one meaning: refuse it rather than keep either.
        if values.iter().any(|(key, _, given)| *key == s.key && *given) {
            return Err(OptionError(format!("{what} option '{}' is given more than once", s.key)));
        }
        let value = parse_value(s.kind, v).ok_or_else(|| {
            OptionError(format!("{what} option '{}' = '{}': expected {}", s.key, excerpt(v), s.kind.accepted()))
        })?;
        values.retain(|(key, _, _)| *key != s.key);
        values.push((s.key, value, true));
    }
    Ok(Options { values })
}

impl Options {
    pub fn get(&self, key: &str) -> Option<Value> {
        self.values.iter().find(|(k, _, _)| *k == key).map(|(_, v, _)| *v)
    }

    /// Every value in schema order (defaults included), as `key=value` joined by `sep`.
    pub fn describe(&self, schema: &[OptionSpec], sep: &str) -> String {
        let parts: Vec<String> =
            schema.iter().filter_map(|s| self.get(s.key).map(|v| format!("{}={v}", s.key))).collect();
        parts.join(sep)
    }

    /// Whether the key was given (not only defaulted).
    pub fn given(&self, key: &str) -> bool {
        self.values.iter().any(|(k, _, given)| *k == key && *given)
    }

    /// An integer key with a default (panics only on a schema mismatch, a programming error that the
    /// registry tests catch).
    pub fn int(&self, key: &str) -> i64 {
        match self.get(key) {
            Some(Value::Int(x)) => x,
            other => panic!("option '{key}' is not an integer with a default: {other:?}"),
        }
    }

    pub fn float(&self, key: &str) -> f64 {
        match self.get(key) {
            Some(Value::Float(x)) => x,
            Some(Value::Int(x)) => x as f64,
            other => panic!("option '{key}' is not a number with a default: {other:?}"),
        }
    }

    pub fn choice(&self, key: &str) -> &'static str {
        match self.get(key) {
            Some(Value::Choice(w)) => w,
            other => panic!("option '{key}' is not a choice with a default: {other:?}"),
        }
    }

    /// A number key without a default: `None` when not given.
    pub fn float_if_given(&self, key: &str) -> Option<f64> {
        match self.get(key) {
            Some(Value::Float(x)) => Some(x),
            Some(Value::Int(x)) => Some(x as f64),
            _ => None,
        }
    }
}

/// One line per key, for `--help`: `  patches  32  an integer in 1..=32  patches per side P`.
pub fn help_lines(schema: &[OptionSpec], indent: &str) -> String {
    let mut out = String::new();
    for s in schema {
        let _ = writeln!(out, "{indent}{}={} ({}): {}", s.key, s.default.unwrap_or("unset"), s.kind.accepted(), s.help);
    }
    out
}

/// A Markdown table of the schema (the option tables of docs/techniques/ are checked against this).
pub fn markdown_table(schema: &[OptionSpec]) -> String {
    let mut out = String::from("| option | default | values | meaning |\n|---|---|---|---|\n");
    for s in schema {
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | {} |",
            s.key,
            s.default.map_or("—".to_string(), |d| format!("`{d}`")),
            s.kind.accepted().replace('|', "\\|"),
            s.help.replace('|', "\\|")
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCHEMA: &[OptionSpec] = &[
        OptionSpec { key: "K", aliases: &["k"], kind: Kind::Int { min: 1, max: 32 }, default: Some("10"), help: "" },
        OptionSpec {
            key: "eps",
            aliases: &[],
            kind: Kind::Float { min: 0.0, max: 1.0, min_open: true, max_open: true },
            default: Some("0.01"),
            help: "",
        },
        OptionSpec { key: "mode", aliases: &[], kind: Kind::Choice(&["a", "b"]), default: Some("a"), help: "" },
        OptionSpec { key: "t", aliases: &[], kind: Kind::Direction, default: None, help: "" },
    ];

    fn pairs(s: &str) -> Vec<(String, String)> {
        split_spec(&format!("x:{s}")).unwrap().1
    }

    #[test]
    fn defaults_values_and_aliases() {
        let o = parse("x", SCHEMA, &pairs("k=4,mode=b,t=0/2/0")).unwrap();
        assert_eq!(o.int("K"), 4);
        assert!(o.given("K") && !o.given("eps"));
        assert_eq!(o.float("eps"), 0.01);
        assert_eq!(o.choice("mode"), "b");
        assert_eq!(o.get("t"), Some(Value::Direction([0.0, 1.0, 0.0])));
        assert_eq!(parse("x", SCHEMA, &[]).unwrap().get("t"), None);
    }

    #[test]
    fn errors_name_the_key_and_the_range() {
        for (spec, needle) in [
            ("K=0", "'K' = '0': expected an integer in 1..=32"),
            ("K=2.5", "'K' = '2.5'"),
            ("eps=1", "'eps' = '1': expected a number in (0, 1)"),
            ("eps=nan", "'eps' = 'nan'"),
            ("eps=inf", "'eps' = 'inf'"),
            ("mode=c", "one of a, b"),
            ("t=0/0/0", "direction"),
            ("t=1/2", "direction"),
            ("bogus=1", "no option 'bogus' (options: K, eps, mode, t)"),
            // A repeated key (the same one, or a key and its alias) is refused, whichever value came last.
            ("K=4,K=8", "'K' is given more than once"),
            ("K=4,k=4", "'K' is given more than once"),
        ] {
            let e = parse("x", SCHEMA, &pairs(spec)).unwrap_err().0;
            assert!(e.contains(needle), "{spec}: {e}");
        }
        assert!(split_spec("x:K").unwrap_err().0.contains("not key=value"));
        assert!(parse("none", &[], &pairs("a=1")).unwrap_err().0.contains("none has no options"));
    }

    #[test]
    fn help_and_table_list_every_key() {
        let t = markdown_table(SCHEMA);
        let h = help_lines(SCHEMA, "  ");
        for s in SCHEMA {
            assert!(
                t.contains(&format!("`{}`", s.key)) && h.contains(&format!("{} (", s.key.split('=').next().unwrap()))
                    || h.contains(&format!("{}=", s.key))
            );
        }
    }
}
