//! How an error reads on the terminal: its chain of causes joined by `: `, each cause once.
//!
//! anyhow's `{:#}` prints every cause of the chain, but many library errors already put their
//! source into their own message (Rerun's `Failed to write: File too large (os error 27)` wraps
//! the `io::Error` it prints), so `{:#}` said the cause twice (issue 28, item 9). [`error_text`]
//! leaves out a cause whose text the line already holds.

/// `e` and its causes joined by `: `, leaving out each cause whose text is already in what
/// precedes it.
pub fn error_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string();
        if text.is_empty() {
            text = part;
        } else if !part.is_empty() && !text.contains(&part) {
            text.push_str(": ");
            text.push_str(&part);
        }
    }
    text
}

/// The edit (Levenshtein) distance between `a` and `b`, in characters: the fewest insertions,
/// deletions and substitutions turning one into the other.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// The known name closest to `name` by [`edit_distance`] (a case-insensitive match first; ties
/// go to the earlier name), when it is close enough to be a misspelling: at most a third of the
/// longer name's characters differ, and at least one or two edits are allowed.
pub fn closest<'a>(name: &str, known: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let mut best: Option<(usize, &'a str)> = None;
    for candidate in known {
        if candidate == name {
            continue;
        }
        let d = if candidate.eq_ignore_ascii_case(name) {
            0
        } else {
            edit_distance(name, candidate)
        };
        let longer = name.chars().count().max(candidate.chars().count());
        if d > (longer / 3).max(2).min(longer.saturating_sub(1)) {
            continue;
        }
        if best.is_none_or(|(b, _)| d < b) {
            best = Some((d, candidate));
        }
    }
    best.map(|(_, c)| c)
}

/// `": did you mean `NAME`?"` naming the [`closest`] known name, or `""` when none is close.
pub fn did_you_mean<'a>(name: &str, known: impl IntoIterator<Item = &'a str>) -> String {
    closest(name, known).map_or_else(String::new, |c| format!(": did you mean `{c}`?"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[derive(Debug, thiserror::Error)]
    #[error("Failed to write: {0}")]
    struct Wrapping(#[source] std::io::Error);

    #[test]
    fn a_cause_already_in_the_message_is_said_once() {
        let io = std::io::Error::from_raw_os_error(27);
        let said = io.to_string();
        let e = Err::<(), _>(Wrapping(io))
            .context("writing x.rrd.part")
            .unwrap_err();
        assert_eq!(format!("{e:#}").matches(&said).count(), 2);
        assert_eq!(
            error_text(&e),
            format!("writing x.rrd.part: Failed to write: {said}")
        );
    }

    #[test]
    fn distinct_causes_are_all_kept_in_order() {
        let e = Err::<(), _>(std::io::Error::other("disk gone"))
            .context("writing a.mcap.part")
            .context("simulating")
            .unwrap_err();
        assert_eq!(error_text(&e), "simulating: writing a.mcap.part: disk gone");
        let single = anyhow::anyhow!("just this");
        assert_eq!(error_text(&single), "just this");
    }

    #[test]
    fn edit_distance_counts_insertions_deletions_substitutions() {
        assert_eq!(edit_distance("", ""), 0);
        assert_eq!(edit_distance("elbow", "elbow"), 0);
        assert_eq!(edit_distance("elbw", "elbow"), 1);
        assert_eq!(edit_distance("elbow", "elbw"), 1);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("flaw", "lawn"), 2);
        assert_eq!(edit_distance("ü", "u"), 1);
    }

    #[test]
    fn the_closest_name_is_suggested_only_when_close() {
        let joints = ["shoulder", "elbow", "wrist"];
        assert_eq!(closest("elbw", joints), Some("elbow"));
        assert_eq!(closest("Elbow", joints), Some("elbow"));
        assert_eq!(closest("sholder_joint", joints), None);
        assert_eq!(closest("wirst", joints), Some("wrist"));
        assert_eq!(closest("xyz", joints), None);
        assert_eq!(closest("elbow", joints), None);
        assert_eq!(closest("a", ["b"]), None);
        assert_eq!(closest("joint_1", ["joint_2", "joint_10"]), Some("joint_2"));
        assert_eq!(did_you_mean("elbw", joints), ": did you mean `elbow`?");
        assert_eq!(did_you_mean("xyz", joints), "");
    }
}
