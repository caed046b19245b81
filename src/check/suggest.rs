//! "Did you mean" suggestions for misspelt names.

/// The closest candidate within an edit distance that scales with the name's length.
pub fn closest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .filter(|c| *c != name)
        .map(|c| (strsim::damerau_levenshtein(name, c), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, c)| (*d, *c))
        .map(|(_, c)| c)
}

/// A help line for a near miss, if there is one.
pub fn did_you_mean<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<String> {
    closest(name, candidates).map(|c| format!("did you mean `{c}`?"))
}

#[cfg(test)]
mod tests {
    #[test]
    fn finds_near_misses_only() {
        let names = ["hypersphere", "hyperbox", "halfspace"];
        assert_eq!(super::closest("hypersphre", names), Some("hypersphere"));
        assert_eq!(super::closest("cube", names), None);
    }
}
