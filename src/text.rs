//! Small helpers for the text people read (summaries, errors, reports), not for machine-readable
//! output (JSON keys, CSV headers stay as they are).

/// `n` and the noun in the number that fits it: `count(1, "gap", "gaps")` is "1 gap",
/// `count(0, "gap", "gaps")` "0 gaps". Both forms are given, so irregular plurals ("1 entry",
/// "2 entries") and phrases ("1 sample stamped", "3 samples stamped") read right too.
pub fn count(n: impl Into<u64>, one: &str, many: &str) -> String {
    let n = n.into();
    format!("{n} {}", if n == 1 { one } else { many })
}

/// A recording's time faults in words, as `import` and the CSV reader both say them: "3 gaps
/// (12 samples missing), 1 duplicate time stamp, 0 samples stamped behind the latest time".
/// `duplicate` names what repeated (singular, plural).
pub fn time_faults(gaps: u64, missing: u64, duplicates: (u64, &str, &str), behind: u64) -> String {
    format!(
        "{} ({} missing), {}, {} behind the latest time",
        count(gaps, "gap", "gaps"),
        count(missing, "sample", "samples"),
        count(duplicates.0, duplicates.1, duplicates.2),
        count(behind, "sample stamped", "samples stamped")
    )
}

/// `v` with at most `places` decimals, trailing zeros dropped (100 → "100", 104.26409 →
/// "104.264" at 3): a rate or range for people, not the float's every digit.
pub fn trim_decimals(v: f64, places: usize) -> String {
    let s = format!("{v:.places$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The names of the flags set, in order: `(name, set)` pairs as a command's arguments give them.
pub fn flags_set<const N: usize>(flags: [(&'static str, bool); N]) -> Vec<&'static str> {
    flags
        .into_iter()
        .filter_map(|(name, set)| set.then_some(name))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_is_singular_everything_else_plural() {
        assert_eq!(count(0u64, "gap", "gaps"), "0 gaps");
        assert_eq!(count(1u64, "gap", "gaps"), "1 gap");
        assert_eq!(count(2u32, "gap", "gaps"), "2 gaps");
        assert_eq!(count(1u8, "entry", "entries"), "1 entry");
    }

    #[test]
    fn decimals_are_trimmed_not_rounded_away() {
        assert_eq!(trim_decimals(100.0, 3), "100");
        assert_eq!(trim_decimals(104.26409, 3), "104.264");
        assert_eq!(trim_decimals(248.5580, 3), "248.558");
        assert_eq!(trim_decimals(2.5, 2), "2.5");
    }
}
