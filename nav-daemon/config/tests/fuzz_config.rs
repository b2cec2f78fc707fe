//! Property tests (proptest) of the configuration parser: no input makes it
//! panic, and a bad value or unknown key is an error that names the file
//! and the key.

use polarnav_config::Config;
use proptest::prelude::*;

const SHIPPED: &str = include_str!("../../../config/nav-daemon.toml");

/// `(table, key)` of every `key = value` line of the shipped configuration.
fn keys() -> Vec<(String, String, usize)> {
    let mut table = String::new();
    let mut out = Vec::new();
    for (i, line) in SHIPPED.lines().enumerate() {
        let l = line.trim();
        if l.starts_with('[') && !l.starts_with("[[") {
            table = l.trim_matches(|c| c == '[' || c == ']').to_owned();
        } else if !l.starts_with('#')
            && let Some((k, _)) = l.split_once('=')
        {
            out.push((table.clone(), k.trim().to_owned(), i));
        }
    }
    out
}

fn with_line(i: usize, replacement: &str) -> String {
    SHIPPED
        .lines()
        .enumerate()
        .map(|(k, l)| if k == i { replacement } else { l })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_shipped_configuration_parses() {
    Config::parse(SHIPPED, "nav-daemon.toml").expect("shipped config");
    assert!(
        keys().len() > 20,
        "the key scan found {} keys",
        keys().len()
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
        let _ = Config::parse(&text, "fuzz.toml");
    }

    #[test]
    fn arbitrary_toml_like_text_never_panics(
        lines in proptest::collection::vec(
            ("[a-z_\\[\\]]{1,20}", "[ =]{0,3}", "[-0-9a-z.\"\\[\\],e+ ]{0,16}"),
            0..20,
        )
    ) {
        let text: String = lines.iter().map(|(k, eq, v)| format!("{k}{eq}{v}\n")).collect();
        let _ = Config::parse(&text, "fuzz.toml");
    }

    /// Any value of any key replaced by junk: either still valid, or an error
    /// that names the file and that key.
    #[test]
    fn a_bad_value_is_an_error_naming_its_key(
        which in any::<prop::sample::Index>(),
        junk in prop_oneof![
            Just("\"text\"".to_owned()),
            Just("-1.0".to_owned()),
            Just("nan".to_owned()),
            Just("inf".to_owned()),
            Just("-inf".to_owned()),
            Just("1e400".to_owned()),
            Just("[1, 2]".to_owned()),
            Just("".to_owned()),
            Just("true".to_owned()),
            Just("{ a = 1 }".to_owned()),
            any::<f64>().prop_map(|x| format!("{x:?}")),
            any::<i64>().prop_map(|x| x.to_string()),
        ],
    ) {
        let all = keys();
        let (table, key, line) = &all[which.index(all.len())];
        let text = with_line(*line, &format!("{key} = {junk}"));
        if let Err(e) = Config::parse(&text, "fuzz.toml") {
            let msg = e.to_string();
            prop_assert!(msg.contains("fuzz.toml"), "{msg}");
            prop_assert!(
                msg.contains(key.as_str()) || msg.contains(&format!("{table}.{key}")),
                "error for {table}.{key} = {junk} does not name the key: {msg}"
            );
        }
    }

    #[test]
    fn an_unknown_key_is_an_error_naming_it(
        which in any::<prop::sample::Index>(),
        name in "[a-z]{3,12}_[a-z]{3,8}",
    ) {
        let all = keys();
        let (_, key, line) = &all[which.index(all.len())];
        prop_assume!(all.iter().all(|(_, k, _)| *k != name));
        let original = SHIPPED.lines().nth(*line).unwrap_or_default();
        let text = with_line(*line, &format!("{original}\n{name} = 1.0"));
        let e = Config::parse(&text, "fuzz.toml").expect_err("unknown key accepted");
        prop_assert!(e.to_string().contains(&name), "{} (after {key})", e);
    }
}
