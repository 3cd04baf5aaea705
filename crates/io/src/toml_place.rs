//! Where a TOML file went wrong, on one line: `file:LINE: field `a.b[2]`:
//! message`. The parser's own `Display` quotes the whole offending line
//! under a caret (a 400 KB line printed whole); every input file names its
//! errors this one way instead.

use toml::de::{DeTable, DeValue};

/// 1-based line of a byte offset in `text`.
pub fn line_of_offset(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The dotted path (`agc.metering`, `ccd.qe.value[3]`) of the deepest key
/// or value of `text` holding byte `offset`; `None` outside every entry
/// (or when `text` is not TOML at all).
pub fn field_at_offset(text: &str, offset: usize) -> Option<String> {
    type Spanned<'a> = toml::Spanned<DeValue<'a>>;
    type Holds<'h> = &'h dyn Fn(&std::ops::Range<usize>) -> bool;
    let holds = |r: &std::ops::Range<usize>| r.start <= offset && offset < r.end.max(r.start + 1);
    // A table's own span may cover only its header (`[[a.b]]`): its
    // entries, and the tables in its arrays, are searched too.
    fn value_holds(v: &Spanned, holds: Holds) -> bool {
        holds(&v.span())
            || match v.get_ref() {
                DeValue::Table(t) => table_holds(t, holds),
                DeValue::Array(a) => a.iter().any(|e| value_holds(e, holds)),
                _ => false,
            }
    }
    fn table_holds(t: &DeTable, holds: Holds) -> bool {
        t.iter()
            .any(|(k, v)| holds(&k.span()) || value_holds(v, holds))
    }
    fn in_value(v: &Spanned, holds: Holds, path: &mut String) {
        match v.get_ref() {
            DeValue::Table(t) => in_table(t, holds, path),
            DeValue::Array(a) => {
                if let Some((i, e)) = a.iter().enumerate().find(|(_, e)| value_holds(e, holds)) {
                    path.push_str(&format!("[{i}]"));
                    in_value(e, holds, path);
                }
            }
            _ => {}
        }
    }
    fn in_table(t: &DeTable, holds: Holds, path: &mut String) {
        let hit = t
            .iter()
            .find(|(k, v)| holds(&k.span()) || holds(&v.span()))
            .or_else(|| t.iter().find(|(_, v)| value_holds(v, holds)));
        if let Some((k, v)) = hit {
            if !path.is_empty() {
                path.push('.');
            }
            path.push_str(k.get_ref());
            in_value(v, holds, path);
        }
    }
    let root = DeTable::parse(text).ok()?;
    let mut path = String::new();
    in_table(root.get_ref(), &holds, &mut path);
    (!path.is_empty()).then_some(path)
}

/// 1-based line of the deepest key of the dotted `field` present in `text`
/// (a missing field is placed at its table; line 1 when nothing is found).
pub fn line_of_field(text: &str, field: &str) -> usize {
    let Ok(root) = DeTable::parse(text) else {
        return 1;
    };
    let mut table = root.get_ref();
    let mut offset = None;
    for k in field.split('.') {
        let Some((key, v)) = table.iter().find(|(key, _)| key.get_ref().as_ref() == k) else {
            break;
        };
        offset = Some(key.span().start);
        match v.get_ref() {
            DeValue::Table(t) => table = t,
            _ => break,
        }
    }
    offset.map_or(1, |o| line_of_offset(text, o))
}

/// A parse or field error of `text` (read from `origin`) on one line:
/// `origin:LINE: field `f`: message` (the field when the error's span
/// lies in an entry).
pub fn one_line(origin: &str, text: &str, e: &toml::de::Error) -> String {
    let (line, message) = place(text, e);
    format!("{origin}:{line}: {message}")
}

/// [`one_line`]'s parts: the 1-based line, and the message after it
/// (`field `f`: …`), for errors that keep the file apart.
pub fn place(text: &str, e: &toml::de::Error) -> (usize, String) {
    let start = e.span().map(|r| r.start);
    let line = start.map_or(1, |s| line_of_offset(text, s));
    let field = start
        .and_then(|s| field_at_offset(text, s))
        .map_or(String::new(), |f| format!("field `{f}`: "));
    (line, format!("{field}{}", e.message().trim()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_nested_unknown_key_is_one_line_with_its_place() {
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct Inner {
            x: f64,
        }
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Outer {
            inner: Inner,
        }
        let long = "y".repeat(10_000);
        let text = format!("# a comment\n[inner]\nx = 1.0\n{long} = 2\n");
        let e = toml::from_str::<Outer>(&text).unwrap_err();
        let m = one_line("f.toml", &text, &e);
        assert!(m.starts_with("f.toml:4: "), "{m}");
        assert!(m.contains("unknown field"), "{m}");
        assert!(!m.contains('\n') && !m.contains('^'), "{m}");
        // The 10 000-byte key appears in the field and the parser's
        // message, not a third time as the quoted line.
        assert_eq!(m.matches(&long).count(), 2, "{}", m.len());
        assert!(m.contains(&format!("field `inner.{long}`")), "{}", m.len());
        assert_eq!(line_of_offset("a\nb\nc", 4), 3);
        assert_eq!(
            field_at_offset("[a]\nb = [1, 2, 3]\n", 15).as_deref(),
            Some("a.b[2]")
        );
        assert_eq!(
            line_of_field("# c\nunits = \"m\"\nsensor = \"x\"\n", "sensor"),
            3
        );
        assert_eq!(line_of_field("units = 1\n", "sensor"), 1);
        assert_eq!(line_of_field("[a]\nx = 1\n[b]\ny = 2\n", "b.y"), 4);
        // An array of tables, whose header alone spans the table.
        let text = "[s]\nk = 1\n[[s.l]]\nx = 1\n[[s.l]]\ny = 2\n";
        let at = text.find("y =").unwrap();
        assert_eq!(field_at_offset(text, at).as_deref(), Some("s.l[1].y"));
    }
}
