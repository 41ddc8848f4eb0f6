//! The log and model parsers on arbitrary input: never a panic; either rows/models or an error
//! that names the file.

use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn log_parser_never_panics(body in "(t,z(,true_dv,true_delta,true_da,true_dw)?\n)?([-0-9.eEnaNif, x\"]{0,40}\n){0,8}") {
        match hal_sim::log::read_from(body.as_bytes(), "fuzz.csv") {
            Ok(rows) => prop_assert!(rows.iter().all(|r| r.t.is_finite())),
            Err(e) => {
                let msg = format!("{:#}", e);
                prop_assert!(msg.contains("fuzz.csv"), "{}", msg);
            }
        }
    }

    #[test]
    fn log_parser_on_raw_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
        if let Err(e) = hal_sim::log::read_from(&bytes[..], "fuzz.csv") {
            let msg = format!("{:#}", e);
            prop_assert!(msg.contains("fuzz.csv"), "{}", msg);
        }
    }

    #[test]
    fn model_parser_never_panics(
        dt in "(-?[0-9.e]{1,6}|nan|inf)",
        sigma_v in "(-?[0-9.e]{1,6}|nan)",
        kind in "(gauss-markov|exp-cosine|random-walk|random-constant|white|pink)",
        a in "(-?[0-9.e]{1,6}|inf)",
        b in "(-?[0-9.e]{1,6})",
    ) {
        let text = format!(
            "dt = {dt}\n[observation]\nsigma_v = {sigma_v}\n[[gyro]]\nkind = \"{kind}\"\nsigma = {a}\ntau = {b}\nbeta = {b}\nq = {a}\ndensity = {a}\n"
        );
        match hal_sim::model_toml::parse(&text, "fuzz.toml") {
            Ok(m) => prop_assert!(m.layout().is_ok()),
            Err(e) => {
                let msg = format!("{:#}", e);
                prop_assert!(msg.contains("fuzz.toml"), "{}", msg);
            }
        }
    }
}
