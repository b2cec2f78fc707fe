//! JSON Schemas derived from a payload's own serialization, and the JSON
//! encoding without padding, so that schema and messages cannot disagree.

use serde::Serialize;
use serde_json::{Map, Value, json};

/// Removes every object key that starts with `_` (the wire's padding bytes).
pub fn strip_padding(v: &mut Value) {
    match v {
        Value::Object(m) => {
            m.retain(|k, _| !k.starts_with('_'));
            m.values_mut().for_each(strip_padding);
        }
        Value::Array(a) => a.iter_mut().for_each(strip_padding),
        _ => {}
    }
}

/// Writes `v` as JSON without its padding fields.
pub fn write_without_padding<T: Serialize>(
    buf: &mut Vec<u8>,
    v: &T,
) -> Result<(), serde_json::Error> {
    let mut value = serde_json::to_value(v)?;
    strip_padding(&mut value);
    serde_json::to_writer(buf, &value)
}

/// The JSON Schema of the values `sample`'s type serializes to: objects with
/// their properties (all required), fixed-length arrays, integers and numbers
/// as serialized, strings.
pub fn json_schema<T: Serialize>(title: &str, sample: &T) -> Value {
    let mut value = serde_json::to_value(sample).unwrap_or(Value::Null);
    strip_padding(&mut value);
    let mut s = schema_of(&value);
    if let Value::Object(m) = &mut s {
        m.insert("title".into(), Value::String(title.into()));
        m.insert(
            "$schema".into(),
            Value::String("https://json-schema.org/draft/2020-12/schema".into()),
        );
    }
    s
}

fn schema_of(v: &Value) -> Value {
    match v {
        Value::Null => json!({ "type": "null" }),
        Value::Bool(_) => json!({ "type": "boolean" }),
        Value::Number(n) if n.is_f64() => json!({ "type": "number" }),
        Value::Number(_) => json!({ "type": "integer" }),
        Value::String(_) => json!({ "type": "string" }),
        Value::Array(a) => {
            let items = a.first().map_or(json!({}), schema_of);
            json!({ "type": "array", "items": items, "minItems": a.len(), "maxItems": a.len() })
        }
        Value::Object(m) => {
            let props: Map<String, Value> =
                m.iter().map(|(k, v)| (k.clone(), schema_of(v))).collect();
            let required: Vec<Value> = m.keys().cloned().map(Value::String).collect();
            json!({ "type": "object", "properties": props, "required": required })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of the solution is in its schema with its JSON type, and
    /// no padding; a real solution's JSON has exactly the schema's keys.
    #[test]
    fn solution_schema_lists_every_field_with_its_type() {
        let s = json_schema("polarnav.Solution", &msgs::Solution::default());
        let props = s["properties"].as_object().expect("properties");
        assert_eq!(props["t_ns"]["type"], "integer");
        assert_eq!(props["lat_rad"]["type"], "number");
        assert_eq!(props["q_b_e"]["type"], "array");
        assert_eq!(props["q_b_e"]["maxItems"], 4);
        assert_eq!(props["q_b_e"]["items"]["type"], "number");
        assert_eq!(props["frame"]["type"], "integer");
        assert!(!props.contains_key("_pad"));
        let sol = msgs::Solution {
            t_ns: 5,
            lat_rad: 1.25,
            frame: 1,
            ..Default::default()
        };
        let mut buf = Vec::new();
        write_without_padding(&mut buf, &sol).expect("encode");
        let v: Value = serde_json::from_slice(&buf).expect("json");
        let mut a: Vec<&String> = v.as_object().expect("object").keys().collect();
        let mut b: Vec<&String> = props.keys().collect();
        a.sort();
        b.sort();
        assert_eq!(a, b);
        assert_eq!(v["lat_rad"], 1.25);
        assert_eq!(v["frame"], 1);
    }

    #[test]
    fn padding_is_stripped_at_every_depth() {
        let mut v =
            json!({ "a": 1, "_pad": [0, 0], "inner": { "_pad": 0, "b": [ { "_x": 1, "c": 2 } ] } });
        strip_padding(&mut v);
        assert_eq!(v, json!({ "a": 1, "inner": { "b": [ { "c": 2 } ] } }));
    }
}
