//! `--shard k/N`: which chunks (part files) one of N machines computes.
//!
//! Chunk `c` belongs to shard `(c mod N) + 1` (round robin, so every shard gets early and late
//! runs alike). A chunk's files depend on the spec and the chunk index alone, so the union of
//! the N shards' files is, byte for byte, the unsharded dataset.

use std::fmt;
use std::str::FromStr;

/// Shard `index` of `count`, 1-based (`1 <= index <= count`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    /// Whether chunk `chunk` is this shard's.
    pub fn owns(&self, chunk: u64) -> bool {
        chunk % self.count == self.index - 1
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    /// `k/N` with `1 <= k <= N`.
    fn from_str(s: &str) -> Result<Self, String> {
        let usage = || format!("expected k/N with 1 <= k <= N (e.g. 1/4), got {s:?}");
        let (k, n) = s.split_once('/').ok_or_else(usage)?;
        let index: u64 = k.trim().parse().map_err(|_| usage())?;
        let count: u64 = n.trim().parse().map_err(|_| usage())?;
        if index == 0 || count == 0 || index > count {
            return Err(usage());
        }
        Ok(Self { index, count })
    }
}

/// `chunk`'s shard among `count` shards.
pub fn shard_of(chunk: u64, count: u64) -> Shard {
    Shard {
        index: chunk % count + 1,
        count,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_partitions() {
        assert_eq!("2/3".parse::<Shard>(), Ok(Shard { index: 2, count: 3 }));
        for bad in ["0/3", "4/3", "1", "a/b", "1/0", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        // Every chunk belongs to exactly one shard.
        for chunk in 0..20 {
            let owners = (1..=3)
                .filter(|&k| Shard { index: k, count: 3 }.owns(chunk))
                .count();
            assert_eq!(owners, 1);
            assert!(shard_of(chunk, 3).owns(chunk));
        }
    }
}
