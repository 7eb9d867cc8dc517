//! Candidate functions for fast orthogonal search: the term types ([`TermSpec`]), the families
//! that generate them ([`Family`]) and materialised candidate columns ([`CandidateSet`]).
//!
//! Tamazin, Noureldin & Korenberg 2013, eq 15: candidates are products of lagged outputs and
//! inputs, `P(n) = y(n-l_1)...y(n-l_i) x(n-k_1)...x(n-k_j)` with `1 <= l <= L`, `0 <= k <= K`.
//! We provide the families the paper uses: the constant, output lags `y(n-l)`, `l = 1..L`
//! (CP degree 1) and the degree-2 cross-products `y(n-l_1) y(n-l_2)`, `1 <= l_1 <= l_2 <= L`
//! (CP degree 2, squares included), plus lagged exogenous inputs `x_i(n-k)`, `k = 0..K`
//! (temperature, other axes).
//!
//! Every term here is a *shifted base series*: `P(n) = B(n - s)` with `B` one of `1`, `y(t)`,
//! `y(t) y(t-g)` or `x_i(t)` (see [`BaseKey`]). FOS uses this to compute inner products of
//! candidates from a few cached lagged products of the base series (`fos_model`).
//!
//! Adding a family (e.g. sine/cosine, step, temperature polynomial for the close-the-loop
//! feature): add a [`TermSpec`] variant with its `name`, `eval` and `shift_form` (a new
//! [`BaseKey`] whose base series is built in `fos_model::build_bases`), and a [`Family`]
//! variant listing its terms. Nothing in the search itself changes.

use super::ModelError;
use crate::stats::{NumError, check_same_len};
use serde::{Deserialize, Serialize};

/// One model term, serialisable (TOML: `[[terms]] kind = "lag", lag = 3`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TermSpec {
    /// The constant 1.
    Constant,
    /// `y(n - lag)`, `lag >= 1`.
    Lag { lag: usize },
    /// `y(n - lag1) * y(n - lag2)`, `1 <= lag1 <= lag2`.
    CrossProduct { lag1: usize, lag2: usize },
    /// `x_input(n - lag)`, `lag >= 0` (lag 0 = the exogenous value at the predicted instant).
    ExoLag { input: usize, lag: usize },
}

/// The base series of a term in its shifted form `P(n) = B(n - shift)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BaseKey {
    /// All ones.
    One,
    /// `y(t)`.
    Y,
    /// `y(t) y(t - gap)`.
    YProd { gap: usize },
    /// `x_input(t)`.
    Exo { input: usize },
}

impl TermSpec {
    /// Readable name: `1`, `y(n-3)`, `y(n-1)*y(n-2)`, `x0(n-0)`.
    pub fn name(&self) -> String {
        match *self {
            TermSpec::Constant => "1".to_string(),
            TermSpec::Lag { lag } => format!("y(n-{lag})"),
            TermSpec::CrossProduct { lag1, lag2 } => format!("y(n-{lag1})*y(n-{lag2})"),
            TermSpec::ExoLag { input, lag } => format!("x{input}(n-{lag})"),
        }
    }

    /// Largest output lag the term reads (0 if none).
    pub fn max_y_lag(&self) -> usize {
        match *self {
            TermSpec::Lag { lag } => lag,
            TermSpec::CrossProduct { lag1, lag2 } => lag1.max(lag2),
            _ => 0,
        }
    }

    /// Number of past samples (including none for lag 0) the term needs before the first
    /// fit row: the largest shift of its base series, with the products' own gap included.
    pub fn history_needed(&self) -> usize {
        match *self {
            TermSpec::Constant => 0,
            TermSpec::Lag { lag } => lag,
            TermSpec::CrossProduct { lag1, lag2 } => lag1.max(lag2),
            TermSpec::ExoLag { lag, .. } => lag,
        }
    }

    /// Check the lags are in range (`Lag` and `CrossProduct` need lags >= 1: they are
    /// predictors of y(n) from its past).
    pub fn validate(&self, n_exo: usize) -> Result<(), ModelError> {
        let bad = |s: String| Err(ModelError::bad(s));
        match *self {
            TermSpec::Lag { lag: 0 } => bad("Lag needs lag >= 1".into()),
            TermSpec::CrossProduct { lag1, lag2 } if lag1 == 0 || lag2 == 0 => {
                bad("CrossProduct needs lags >= 1".into())
            }
            TermSpec::ExoLag { input, .. } if input >= n_exo => bad(format!(
                "ExoLag input {input} but only {n_exo} exogenous series"
            )),
            _ => Ok(()),
        }
    }

    /// Value of the term given accessors for `y(n - lag)` and `x_i(n - lag)`.
    #[inline]
    pub fn eval(&self, y_lag: impl Fn(usize) -> f64, x_lag: impl Fn(usize, usize) -> f64) -> f64 {
        match *self {
            TermSpec::Constant => 1.0,
            TermSpec::Lag { lag } => y_lag(lag),
            TermSpec::CrossProduct { lag1, lag2 } => y_lag(lag1) * y_lag(lag2),
            TermSpec::ExoLag { input, lag } => x_lag(input, lag),
        }
    }

    /// The term as a shifted base series `B(n - shift)`.
    pub fn shift_form(&self) -> (BaseKey, usize) {
        match *self {
            TermSpec::Constant => (BaseKey::One, 0),
            TermSpec::Lag { lag } => (BaseKey::Y, lag),
            TermSpec::CrossProduct { lag1, lag2 } => {
                let (a, b) = (lag1.min(lag2), lag1.max(lag2));
                // y(n-a) y(n-b) = W(n-a) with W(t) = y(t) y(t-(b-a))
                (BaseKey::YProd { gap: b - a }, a)
            }
            TermSpec::ExoLag { input, lag } => (BaseKey::Exo { input }, lag),
        }
    }
}

/// A family of candidate terms.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Family {
    /// The constant term.
    Constant,
    /// `y(n-l)`, `l = 1..=max_lag` (CP degree 1).
    Lags { max_lag: usize },
    /// `y(n-l1) y(n-l2)`, `1 <= l1 <= l2 <= max_lag` (CP degree 2; squares included).
    CrossProducts { max_lag: usize },
    /// `x_input(n-k)`, `k = 0..=max_lag`.
    ExoLags { input: usize, max_lag: usize },
}

impl Family {
    /// The terms of the family, in a fixed order.
    pub fn terms(&self) -> Vec<TermSpec> {
        match *self {
            Family::Constant => vec![TermSpec::Constant],
            Family::Lags { max_lag } => (1..=max_lag).map(|lag| TermSpec::Lag { lag }).collect(),
            Family::CrossProducts { max_lag } => {
                let mut v = Vec::new();
                for lag1 in 1..=max_lag {
                    for lag2 in lag1..=max_lag {
                        v.push(TermSpec::CrossProduct { lag1, lag2 });
                    }
                }
                v
            }
            Family::ExoLags { input, max_lag } => (0..=max_lag)
                .map(|lag| TermSpec::ExoLag { input, lag })
                .collect(),
        }
    }

    /// The paper's candidate set for maximum output lag `max_lag` and cross-product degree
    /// `cp_degree` (1 or 2): constant, lags, and for degree 2 the cross-products; plus
    /// `x_i(n-k)`, `k = 0..=exo_max_lag`, for each of `n_exo` exogenous series.
    pub fn paper_set(
        max_lag: usize,
        cp_degree: usize,
        n_exo: usize,
        exo_max_lag: usize,
    ) -> Vec<Family> {
        let mut f = vec![Family::Constant, Family::Lags { max_lag }];
        if cp_degree >= 2 {
            f.push(Family::CrossProducts { max_lag });
        }
        for input in 0..n_exo {
            f.push(Family::ExoLags {
                input,
                max_lag: exo_max_lag,
            });
        }
        f
    }
}

/// All terms of a list of families, duplicates removed (first occurrence kept).
pub fn family_terms(families: &[Family]) -> Vec<TermSpec> {
    let mut out: Vec<TermSpec> = Vec::new();
    for f in families {
        for t in f.terms() {
            if !out.contains(&t) {
                out.push(t);
            }
        }
    }
    out
}

/// Materialised candidate columns over the fit rows `n = first_row..N`.
#[derive(Debug, Clone, PartialEq)]
pub struct CandidateSet {
    /// Name of each candidate (see [`TermSpec::name`]).
    pub names: Vec<String>,
    /// Column m holds `p_m(n)` for `n = first_row..N`.
    pub columns: Vec<Vec<f64>>,
    /// The term behind each column.
    pub specs: Vec<TermSpec>,
    /// First sample index with every lag available (the largest history needed).
    pub first_row: usize,
}

impl CandidateSet {
    /// Build the columns of `families` for output `y` and exogenous series `exo` (each the
    /// same length as `y`). Rows start at the largest lag so every term is defined.
    pub fn build(y: &[f64], exo: &[&[f64]], families: &[Family]) -> Result<Self, ModelError> {
        let specs = family_terms(families);
        Self::from_specs(y, exo, &specs)
    }

    /// Build the columns of explicit terms.
    pub fn from_specs(y: &[f64], exo: &[&[f64]], specs: &[TermSpec]) -> Result<Self, ModelError> {
        for x in exo {
            check_same_len(y.len(), x.len())?;
        }
        for t in specs {
            t.validate(exo.len())?;
        }
        let first_row = specs.iter().map(|t| t.history_needed()).max().unwrap_or(0);
        if y.len() <= first_row + 1 {
            return Err(NumError::TooShort {
                needed: first_row + 2,
                got: y.len(),
            }
            .into());
        }
        let columns = specs
            .iter()
            .map(|t| {
                (first_row..y.len())
                    .map(|n| t.eval(|l| y[n - l], |i, l| exo[i][n - l]))
                    .collect()
            })
            .collect();
        Ok(CandidateSet {
            names: specs.iter().map(|t| t.name()).collect(),
            columns,
            specs: specs.to_vec(),
            first_row,
        })
    }

    /// The fit target `y(n)` on the same rows as the columns.
    pub fn target<'a>(&self, y: &'a [f64]) -> &'a [f64] {
        &y[self.first_row.min(y.len())..]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cp2_family_sizes_match_paper_counts() {
        // L = 10: 1 constant + 10 lags + 55 cross-products (l1 <= l2) = 66 candidates.
        let t = family_terms(&Family::paper_set(10, 2, 0, 0));
        assert_eq!(t.len(), 66);
        let t1 = family_terms(&Family::paper_set(10, 1, 1, 2));
        assert_eq!(t1.len(), 1 + 10 + 3);
    }

    #[test]
    fn columns_hold_the_lagged_products() {
        let y: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let x: Vec<f64> = (0..10).map(|i| 100.0 + i as f64).collect();
        let specs = [
            TermSpec::Constant,
            TermSpec::Lag { lag: 2 },
            TermSpec::CrossProduct { lag1: 1, lag2: 3 },
            TermSpec::ExoLag { input: 0, lag: 0 },
        ];
        let c = CandidateSet::from_specs(&y, &[&x], &specs).unwrap();
        assert_eq!(c.first_row, 3);
        // row 0 is n = 3
        assert_eq!(c.columns[0][0], 1.0);
        assert_eq!(c.columns[1][0], 1.0); // y(1)
        assert_eq!(c.columns[2][0], 2.0 * 0.0); // y(2) y(0)
        assert_eq!(c.columns[2][1], 3.0 * 1.0); // n=4: y(3) y(1)
        assert_eq!(c.columns[3][0], 103.0);
        assert_eq!(c.target(&y)[0], 3.0);
        assert_eq!(c.names[2], "y(n-1)*y(n-3)");
    }

    #[test]
    fn shift_form_reproduces_the_term() {
        let y: Vec<f64> = (0..20).map(|i| ((i * 7) % 5) as f64 - 1.5).collect();
        for t in family_terms(&Family::paper_set(4, 2, 0, 0)) {
            let (b, s) = t.shift_form();
            for n in 4..20 {
                let base = |tt: usize| match b {
                    BaseKey::One => 1.0,
                    BaseKey::Y => y[tt],
                    BaseKey::YProd { gap } => y[tt] * y[tt - gap],
                    BaseKey::Exo { .. } => unreachable!(),
                };
                assert_eq!(base(n - s), t.eval(|l| y[n - l], |_, _| 0.0), "{t:?}");
            }
        }
    }

    #[test]
    fn invalid_terms_are_rejected() {
        let y = [0.0; 10];
        assert!(CandidateSet::from_specs(&y, &[], &[TermSpec::Lag { lag: 0 }]).is_err());
        assert!(
            CandidateSet::from_specs(&y, &[], &[TermSpec::ExoLag { input: 0, lag: 0 }]).is_err()
        );
    }
}
