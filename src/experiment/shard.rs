//! Sharding an experiment over processes or machines, and merging the shards.
//!
//! An experiment is a deterministic list of work items (trials, runs, pairs), each run by a
//! pure function of its item and the settings. `--shard K/N` deals the items round robin in
//! a fixed shuffled order and runs the K-th hand ([`Shard::items_of`]: near-equal counts, and
//! the same mix of conditions in every shard whatever the period of the item order) and writes their
//! per-item records to `DIR/shard.cbor` instead of a report (CBOR, which keeps every float
//! exactly, NaN and infinities included, where JSON would turn them into nulls). `rodlog experiment merge`
//! reads the shard files, checks that they come from the same build, the same arguments and
//! cover every item exactly once, and runs the experiment again in *merged* mode: the items
//! are not run, their records are taken from the shards, and every table, plot and number of
//! the report is recomputed from them by the same code as an unsharded run. Timing fields
//! (wall times) are the shards' own.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// Seed of the shuffle that deals an experiment's items to shards ([`Shard::items_of`]).
pub const DEAL_SEED: u64 = 0x5A4D_D3A1;

/// Name of a shard's record file.
pub const SHARD_FILE: &str = "shard.cbor";

/// One shard `index` of `count` (`--shard K/N`, 0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// K: this shard.
    pub index: usize,
    /// N: how many shards.
    pub count: usize,
}

impl Shard {
    /// Parses `K/N` with `0 <= K < N`.
    ///
    /// # Errors
    /// Anything else, with the expected form.
    pub fn parse(text: &str) -> Result<Self> {
        let bad = || anyhow::anyhow!("--shard {text:?}: expected K/N with 0 <= K < N, e.g. 0/4");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let index: usize = k.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }

    /// The items of an experiment of `items` items that this shard runs, ascending.
    ///
    /// The items are shuffled by a fixed Fisher-Yates permutation (SplitMix64 seeded with
    /// [`DEAL_SEED`], so every shard and every machine deals the same hands) and dealt round
    /// robin: each shard gets `items / N` or one more. Dealing in item order would hand a
    /// shard every item of one condition whenever the conditions alternate with a period
    /// that divides N (the task experiment's runs alternate a 6 s and a 1 s condition: with
    /// two shards, one got all the long runs).
    #[must_use]
    pub fn items_of(self, items: usize) -> Vec<usize> {
        let mut order: Vec<usize> = (0..items).collect();
        let mut rng = rng::SplitMix64::new(DEAL_SEED);
        for j in (1..items).rev() {
            order.swap(j, rng.below(j + 1));
        }
        let mut mine: Vec<usize> = order
            .into_iter()
            .enumerate()
            .filter(|(p, _)| p % self.count == self.index)
            .map(|(_, i)| i)
            .collect();
        mine.sort_unstable();
        mine
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The build an experiment ran with: shards of different builds are never merged.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Build {
    /// `rodlog` version.
    pub version: String,
    /// Git commit of the source tree (`unknown` outside a git checkout).
    pub git_commit: String,
}

impl Build {
    /// This binary's build.
    #[must_use]
    pub fn current() -> Self {
        Self {
            version: env!("CARGO_PKG_VERSION").to_owned(),
            git_commit: option_env!("RODLOG_GIT_COMMIT")
                .unwrap_or("unknown")
                .to_owned(),
        }
    }
}

/// A shard's record file.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShardFile {
    /// The experiment.
    pub experiment: String,
    /// The build.
    pub build: Build,
    /// The experiment's arguments (seed, trials, image scale, its own options), as JSON.
    pub arguments: String,
    /// Which shard.
    pub shard: Shard,
    /// Items of the whole experiment.
    pub items: usize,
    /// Wall time of the shard's items (s).
    pub wall_s: f64,
    /// `(item index, record)` of every item of the shard, in index order.
    pub records: Vec<(usize, ciborium::Value)>,
}

/// How an experiment's items are run in this process.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Mode {
    /// Every item, then the report.
    #[default]
    All,
    /// The items of one shard, then `shard.json`; no report.
    Shard(Shard),
    /// No item is run: the records of every item come from merged shards, then the report.
    Merged(Merged),
}

/// Records gathered from shard files.
#[derive(Clone, Debug, PartialEq)]
pub struct Merged {
    /// Record of each item.
    pub records: BTreeMap<usize, ciborium::Value>,
    /// Per shard: its index, wall time and folder, for the merged results.json.
    pub shards: Vec<(Shard, f64, PathBuf)>,
}

/// Runs an experiment's `items` as `mode` says: `run` gets the indices to run (in order) and
/// returns their records. Returns every item's record, or `None` for a shard (whose records
/// were written to `out/shard.json`; the experiment then stops without a report).
///
/// # Errors
/// `run`'s errors; a merged record that does not fit the experiment's record type; missing
/// items; writing the shard file.
pub fn run_items<R, F>(
    mode: &Mode,
    experiment: &str,
    arguments: &str,
    items: usize,
    out: &Path,
    run: F,
) -> Result<Option<Vec<R>>>
where
    R: Serialize + DeserializeOwned,
    F: FnOnce(&[usize]) -> Result<Vec<R>>,
{
    match mode {
        Mode::All => {
            let all: Vec<usize> = (0..items).collect();
            Ok(Some(run(&all)?))
        }
        Mode::Shard(shard) => {
            let mine = shard.items_of(items);
            let started = std::time::Instant::now();
            let records = run(&mine)?;
            let wall_s = started.elapsed().as_secs_f64();
            let file = ShardFile {
                experiment: experiment.to_owned(),
                build: Build::current(),
                arguments: arguments.to_owned(),
                shard: *shard,
                items,
                wall_s,
                records: mine
                    .iter()
                    .zip(&records)
                    .map(|(i, r)| Ok((*i, ciborium::Value::serialized(r)?)))
                    .collect::<Result<_>>()?,
            };
            let path = out.join(SHARD_FILE);
            let mut bytes = Vec::new();
            ciborium::into_writer(&file, &mut bytes)
                .with_context(|| format!("encoding {}", path.display()))?;
            std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
            crate::cmd::print_stdout(&format!(
                "shard {shard}: {} of {items} items in {wall_s:.1} s -> {}",
                mine.len(),
                path.display()
            ))?;
            Ok(None)
        }
        Mode::Merged(merged) => {
            if merged.records.len() != items {
                bail!(
                    "the shards hold {} records, the experiment has {items} items: were they made with other arguments?",
                    merged.records.len()
                );
            }
            (0..items)
                .map(|i| {
                    let v = merged
                        .records
                        .get(&i)
                        .with_context(|| format!("no shard holds item {i}"))?;
                    v.deserialized()
                        .with_context(|| format!("item {i}'s record does not fit {experiment}"))
                })
                .collect::<Result<Vec<R>>>()
                .map(Some)
        }
    }
}

/// Reads and checks shard folders: one experiment, one build, one set of arguments, one
/// shard count, every shard present once and every item exactly once.
///
/// # Errors
/// Unreadable files, and every mismatch, named with the folders concerned.
pub fn read_shards(dirs: &[PathBuf]) -> Result<(ShardFile, Merged)> {
    let mut files: Vec<(PathBuf, ShardFile)> = Vec::new();
    for d in dirs {
        let path = d.join(SHARD_FILE);
        let bytes = std::fs::read(&path).with_context(|| {
            format!(
                "cannot read {} (run the experiment with --shard K/N --out {} first)",
                path.display(),
                d.display()
            )
        })?;
        let file: ShardFile = ciborium::from_reader(bytes.as_slice())
            .with_context(|| format!("{} is not a shard file", path.display()))?;
        files.push((d.clone(), file));
    }
    let Some((first_dir, first)) = files.first().cloned() else {
        bail!("experiment merge: no shard folders given");
    };
    for (dir, f) in &files[1..] {
        let differ = |what: &str, a: String, b: String| {
            anyhow::anyhow!(
                "cannot merge {} with {}: different {what} ({a} against {b})",
                dir.display(),
                first_dir.display()
            )
        };
        if f.experiment != first.experiment {
            return Err(differ(
                "experiments",
                f.experiment.clone(),
                first.experiment.clone(),
            ));
        }
        if f.build != first.build {
            return Err(differ(
                "builds",
                format!("{} {}", f.build.version, f.build.git_commit),
                format!("{} {}", first.build.version, first.build.git_commit),
            ));
        }
        if f.arguments != first.arguments {
            return Err(differ(
                "arguments (seed, trials, options)",
                f.arguments.clone(),
                first.arguments.clone(),
            ));
        }
        if f.shard.count != first.shard.count || f.items != first.items {
            return Err(differ(
                "shard counts",
                format!("{} shards of {} items", f.shard.count, f.items),
                format!("{} shards of {} items", first.shard.count, first.items),
            ));
        }
    }
    let mut seen: BTreeMap<usize, PathBuf> = BTreeMap::new();
    for (dir, f) in &files {
        if let Some(other) = seen.insert(f.shard.index, dir.clone()) {
            bail!(
                "shard {} is given twice: {} and {}",
                f.shard,
                other.display(),
                dir.display()
            );
        }
    }
    let missing: Vec<String> = (0..first.shard.count)
        .filter(|k| !seen.contains_key(k))
        .map(|k| format!("{k}/{}", first.shard.count))
        .collect();
    if !missing.is_empty() {
        bail!("missing shards: {}", missing.join(", "));
    }
    let mut records = BTreeMap::new();
    let mut shards = Vec::new();
    for (dir, f) in files {
        let dealt: std::collections::BTreeSet<usize> =
            f.shard.items_of(f.items).into_iter().collect();
        for (i, r) in f.records {
            if !dealt.contains(&i) {
                bail!(
                    "{}: item {i} does not belong to shard {}",
                    dir.display(),
                    f.shard
                );
            }
            records.insert(i, r);
        }
        shards.push((f.shard, f.wall_s, dir));
    }
    shards.sort_by_key(|(s, _, _)| s.index);
    Ok((first, Merged { records, shards }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_deal_every_item_once() -> Result<()> {
        let s = Shard::parse("1/3")?;
        assert_eq!((s.index, s.count), (1, 3));
        assert!(Shard::parse("3/3").is_err() && Shard::parse("0/0").is_err());
        assert!(Shard::parse("x").is_err() && Shard::parse("1/").is_err());
        // Dealt items: every item once, near-equal hands, the same hands on every call.
        let hands: Vec<Vec<usize>> = (0..3)
            .map(|k| Shard { index: k, count: 3 }.items_of(7))
            .collect();
        let mut all: Vec<usize> = hands.concat();
        all.sort_unstable();
        assert_eq!(all, (0..7).collect::<Vec<_>>());
        assert!(
            hands.iter().all(|h| h.len() == 2 || h.len() == 3),
            "{hands:?}"
        );
        assert_eq!(hands[1], s.items_of(7));
        // Two alternating conditions are mixed in both halves, not one condition per shard.
        for k in 0..2 {
            let hand = Shard { index: k, count: 2 }.items_of(40);
            let even = hand.iter().filter(|&&i| i % 2 == 0).count();
            assert!(
                (5..=15).contains(&even),
                "shard {k}: {even} even items of {}",
                hand.len()
            );
        }
        Ok(())
    }

    #[test]
    fn shards_round_trip_and_merge_in_item_order() -> Result<()> {
        let dir = tempfile::tempdir()?;
        let args = r#"{"seed": 1}"#;
        let mut dirs = Vec::new();
        for k in 0..2 {
            let d = dir.path().join(format!("s{k}"));
            std::fs::create_dir_all(&d)?;
            let mode = Mode::Shard(Shard { index: k, count: 2 });
            let out: Option<Vec<f64>> = run_items(&mode, "x", args, 5, &d, |ids| {
                // Non-finite floats survive the shard file.
                Ok(ids
                    .iter()
                    .map(|&i| if i == 3 { f64::NAN } else { 10.0 * i as f64 })
                    .collect())
            })?;
            assert!(out.is_none());
            dirs.push(d);
        }
        let (first, merged) = read_shards(&dirs)?;
        assert_eq!(first.items, 5);
        let all: Vec<f64> = run_items(&Mode::Merged(merged), "x", args, 5, dir.path(), |_| {
            bail!("merged mode runs nothing")
        })?
        .unwrap_or_default();
        assert_eq!(all.len(), 5);
        assert!(all[3].is_nan());
        assert_eq!(all[4], 40.0);
        // A missing shard and a repeated one are refused.
        assert!(read_shards(&dirs[..1]).is_err());
        assert!(read_shards(&[dirs[0].clone(), dirs[0].clone()]).is_err());
        Ok(())
    }
}
