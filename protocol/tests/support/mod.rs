//! What the golden-vector tests share.

use serde_json::Value;

/// Whether `a` and `b` are the same JSON, reals to the last bit or two
/// (JSON text does not promise a real's last bit back; the bytes and the
/// quantized indices, integers, are compared exactly).
pub fn same(a: &Value, b: &Value, at: &str) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            // In any order (serde_json keeps insertion order where another
            // crate of the build asks it to, else sorts).
            let keys = |o: &serde_json::Map<String, Value>| {
                let mut k: Vec<String> = o.keys().cloned().collect();
                k.sort();
                k
            };
            assert_eq!(keys(x), keys(y), "{at}");
            for (k, v) in x {
                same(v, &y[k], &format!("{at}.{k}"));
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}: length");
            for (i, (v, w)) in x.iter().zip(y).enumerate() {
                same(v, w, &format!("{at}[{i}]"));
            }
        }
        (Value::Number(x), Value::Number(y)) if x.is_f64() || y.is_f64() => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!((x - y).abs() <= 1e-15 * x.abs().max(1.0), "{at}: {x} ≠ {y}");
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

/// Compares `now` with the vectors stored in `file` (rewriting the file
/// first when `INERTIA_WRITE_VECTORS` is set), naming `what` on a mismatch.
pub fn check_vectors(file: &str, now: &Value, what: &str) {
    if std::env::var_os("INERTIA_WRITE_VECTORS").is_some() {
        let text = serde_json::to_string_pretty(now).unwrap() + "\n";
        std::fs::write(file, text).unwrap();
    }
    let text = std::fs::read_to_string(file).expect("the vectors file");
    let stored: Value = serde_json::from_str(&text).unwrap();
    same(&stored, now, what);
}
