//! The `KIND:key=value,…` syntax every `--inject` shares (`sledid replay`, `control`, `seek`,
//! `pil`): a spec split into its kind and its pairs, the keys checked against the kind's, the
//! values parsed; every error names the spec as given.

use std::fmt::Display;
use std::str::FromStr;

/// One `--inject` spec, split.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Spec<'a> {
    /// The spec as given.
    pub text: &'a str,
    /// What comes before the `:` (the whole spec when there is none).
    pub kind: &'a str,
    pairs: Vec<(&'a str, &'a str)>,
}

impl<'a> Spec<'a> {
    /// Splits `text` into its kind and `key=value` pairs (empty pairs skipped).
    ///
    /// # Errors
    /// A pair without `=`, named.
    pub fn parse(text: &'a str) -> Result<Self, String> {
        let (kind, rest) = text.split_once(':').unwrap_or((text, ""));
        let pairs = rest
            .split(',')
            .filter(|p| !p.is_empty())
            .map(|p| {
                p.split_once('=')
                    .ok_or_else(|| format!("--inject `{text}`: `{p}` is not key=value"))
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { text, kind, pairs })
    }

    /// An error about this spec: `--inject `spec`: what`.
    pub fn error(&self, what: impl Display) -> String {
        format!("--inject `{}`: {what}", self.text)
    }

    /// Refuses a key that is not in `known` (the kind's keys).
    ///
    /// # Errors
    /// The first unknown key, with the kind's keys.
    pub fn only_keys(&self, known: &[&str]) -> Result<(), String> {
        match self.pairs.iter().find(|(k, _)| !known.contains(k)) {
            Some((k, _)) => Err(self.error(format_args!(
                "unknown key `{k}` for `{}` (keys: {})",
                self.kind,
                known.join(", ")
            ))),
            None => Ok(()),
        }
    }

    /// True when the spec gives `name`.
    pub fn has(&self, name: &str) -> bool {
        self.pairs.iter().any(|(k, _)| *k == name)
    }

    /// The value of `name`, parsed.
    ///
    /// # Errors
    /// `name` missing, or its value not a `T`.
    pub fn value<T: FromStr>(&self, name: &str) -> Result<T, String> {
        let (_, v) = self
            .pairs
            .iter()
            .find(|(k, _)| *k == name)
            .ok_or_else(|| self.error(format_args!("missing `{name}=`")))?;
        v.parse()
            .map_err(|_| self.error(format_args!("`{name}={v}` is not a valid value")))
    }

    /// The value of `name`, parsed, or `default` when the spec does not give it.
    ///
    /// # Errors
    /// Its value not a `T`.
    pub fn value_or<T: FromStr>(&self, name: &str, default: T) -> Result<T, String> {
        if self.has(name) {
            self.value(name)
        } else {
            Ok(default)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kind, the pairs and each error naming the spec. Trips on a parser that drops a pair's
    /// check or names the wrong spec.
    #[test]
    fn splits_and_names_the_spec() {
        let s = Spec::parse("lost:at=5,n=3").expect("splits");
        assert_eq!(s.kind, "lost");
        assert_eq!(s.value::<u32>("at"), Ok(5));
        assert_eq!(s.value_or::<u32>("n", 1), Ok(3));
        assert_eq!(s.value_or::<u32>("every", 7), Ok(7));
        assert_eq!(
            s.value::<u32>("from"),
            Err("--inject `lost:at=5,n=3`: missing `from=`".to_owned())
        );
        assert_eq!(
            s.only_keys(&["at"]),
            Err("--inject `lost:at=5,n=3`: unknown key `n` for `lost` (keys: at)".to_owned())
        );
        assert_eq!(
            Spec::parse("lost:at").map(|_| ()),
            Err("--inject `lost:at`: `at` is not key=value".to_owned())
        );
        let bad = Spec::parse("lost:at=x").expect("splits");
        assert_eq!(
            bad.value::<u32>("at"),
            Err("--inject `lost:at=x`: `at=x` is not a valid value".to_owned())
        );
        assert_eq!(Spec::parse("flip").map(|s| s.kind), Ok("flip"));
    }
}
