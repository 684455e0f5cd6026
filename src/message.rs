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
}
