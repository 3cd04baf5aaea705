//! JSON records read as values with every object's keys given once.
//! `serde_json::Value` keeps the last of a repeated key: a `frames.jsonl`
//! line `"gain":100.0,"gain":300.0` was applied at gain 300 though the
//! frame was taken at 100. A record that contradicts itself is refused,
//! as the typed readers (serde's derive) already refuse it.

use serde::de::{Deserialize, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Number, Value};

/// `text` parsed as one JSON value; an object holding a key twice is an
/// error naming the key (with serde_json's line and column).
pub fn parse_value(text: &str) -> Result<Value, serde_json::Error> {
    serde_json::from_str::<Strict>(text).map(|s| s.0)
}

/// A value whose objects hold each key once.
struct Strict(Value);

impl<'de> Deserialize<'de> for Strict {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(StrictVisitor).map(Strict)
    }
}

struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = Value;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Value, E> {
        Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| E::custom(format!("{v} is not a JSON number")))
    }
    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_owned()))
    }
    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }
    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut out = Vec::new();
        while let Some(Strict(v)) = seq.next_element()? {
            out.push(v);
        }
        Ok(Value::Array(out))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut out = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            if out.contains_key(&key) {
                return Err(A::Error::custom(format!(
                    "the key `{}` is given twice in one object; a record holds each once",
                    crate::shown(&key)
                )));
            }
            let Strict(v) = map.next_value()?;
            out.insert(key, v);
        }
        Ok(Value::Object(out))
    }
}

#[cfg(test)]
mod tests {
    use super::parse_value;

    #[test]
    fn a_repeated_key_is_refused_at_any_depth_and_values_read_as_serde_json_reads_them() {
        let text = r#"{"a":[1,-2,3.5e-310,"x",null,true,{"b":{}}],"c":0.1}"#;
        assert_eq!(
            parse_value(text).unwrap(),
            serde_json::from_str::<serde_json::Value>(text).unwrap()
        );
        for bad in [
            r#"{"gain":100.0,"gain":300.0}"#,
            r#"{"files":[{"path":"a","path":"b"}]}"#,
            r#"[{"x":{"complete":false,"complete":true}}]"#,
        ] {
            let e = parse_value(bad).unwrap_err().to_string();
            assert!(e.contains("given twice"), "{bad}: {e}");
        }
        // Deeper than serde_json's recursion limit: an error, not a stack overflow.
        let deep = "[".repeat(100_000);
        assert!(parse_value(&deep).is_err());
    }
}
