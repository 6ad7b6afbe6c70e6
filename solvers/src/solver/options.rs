//! A solver's own options (`[solver.<name>]` in a config): passed through as given, and read
//! by the solver's catalogue entry into its typed options (unknown keys refused, its own
//! checks), the solver's defaults for what is not given.

use serde::de::DeserializeOwned;

/// A solver's options as given: a table (empty when there is none), in the configs' format.
pub type RawOptions = toml::Table;

/// A solver's typed options.
pub trait Options: DeserializeOwned + Default {
    /// Why a value is outside the option's domain, naming the key.
    fn check(&self) -> Result<(), String> {
        Ok(())
    }
}

/// `raw` read as `T` and checked (`T`'s defaults for the keys not given).
pub fn read<T: Options>(raw: &RawOptions) -> Result<T, String> {
    let options = T::deserialize(toml::Value::Table(raw.clone())).map_err(|e| e.to_string().trim().to_string())?;
    options.check()?;
    Ok(options)
}

/// Whether `raw` reads as `T` (a catalogue entry's check of its table).
pub fn check<T: Options>(raw: &RawOptions) -> Result<(), String> {
    read::<T>(raw).map(|_| ())
}

/// The options of a solver that has none: an empty table or none at all.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoOptions {}

impl Options for NoOptions {}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> RawOptions {
        text.parse().unwrap()
    }

    #[derive(Debug, Default, PartialEq, serde::Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct Two {
        a: f64,
        b: usize,
    }

    impl Options for Two {
        fn check(&self) -> Result<(), String> {
            if self.a < 0.0 {
                return Err(format!("a = {}: it must not be negative", self.a));
            }
            Ok(())
        }
    }

    #[test]
    fn a_table_reads_into_its_type_with_defaults_and_checks() {
        assert_eq!(read::<Two>(&RawOptions::new()), Ok(Two::default()));
        assert_eq!(read::<Two>(&table("b = 3")), Ok(Two { a: 0.0, b: 3 }));
        assert_eq!(read::<Two>(&table("a = -1.0")), Err("a = -1: it must not be negative".to_string()));
        let unknown = read::<Two>(&table("c = 1")).unwrap_err();
        assert_eq!(unknown, "unknown field `c`, expected `a` or `b`");
        let wrong = read::<Two>(&table("b = \"three\"")).unwrap_err();
        assert!(wrong.contains("invalid type"), "{wrong}");
        assert_eq!(check::<NoOptions>(&RawOptions::new()), Ok(()));
        assert!(check::<NoOptions>(&table("tau = 0.1")).unwrap_err().contains("unknown field `tau`"));
    }
}
