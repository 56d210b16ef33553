//! Feature tracks across views: the `m` features of eq. 15, each seen in several of the `n`
//! views (visibility `v_ij = 1` when feature `i` is observed in view `j`).
//!
//! The pairwise matches (GMS, optionally only those consistent with the pair's motion) are
//! edges between keypoints `(view, index)`; a track is a connected component of that graph
//! (union-find). A component holding two different keypoints of the same view is a chain of
//! matches that contradicts itself (one physical point has one image per view), so it is
//! dropped whole; so is a component seen in a single view. Tracks are ordered by their
//! smallest `(view, index)`, and each track's observations by view, so the result depends
//! only on the matches, never on the thread count.

use super::pairs::PairMatches;

/// One observation of a track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackObservation {
    /// View index `j`.
    pub view: usize,
    /// Keypoint index in that view's features.
    pub keypoint: u32,
    /// Full-resolution pixel position `(x, y)`.
    pub px: [f32; 2],
    /// Pyramid level of the keypoint.
    pub level: u8,
}

/// A feature tracked over at least two views, one observation per view, sorted by view.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Its observations.
    pub observations: Vec<TrackObservation>,
}

/// What [`build_tracks`] made of the matches.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracks {
    /// The tracks (module docs for their order).
    pub tracks: Vec<Track>,
    /// Components dropped because they hold two keypoints of one view.
    pub conflicting: usize,
}

fn find(parent: &mut [u32], mut a: u32) -> u32 {
    while let Some(&p) = parent.get(a as usize) {
        if p == a {
            break;
        }
        // Path halving.
        let gp = parent.get(p as usize).copied().unwrap_or(p);
        if let Some(slot) = parent.get_mut(a as usize) {
            *slot = gp;
        }
        a = gp;
    }
    a
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    // The smaller id is the root, so roots do not depend on the union order.
    let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
    if let Some(slot) = parent.get_mut(hi as usize) {
        *slot = lo;
    }
}

/// Tracks from the matches of the pairs `matches[k]` with `use_pair(k)`, taking the matches
/// `m` with `use_match(k, m)`; `keypoints_per_view[j]` is view `j`'s keypoint count. Matches
/// naming a view or keypoint out of range are ignored.
pub fn build_tracks(
    matches: &[PairMatches],
    keypoints_per_view: &[usize],
    use_pair: impl Fn(usize) -> bool,
    use_match: impl Fn(usize, usize) -> bool,
) -> Tracks {
    let mut offset = Vec::with_capacity(keypoints_per_view.len() + 1);
    let mut total = 0usize;
    for &n in keypoints_per_view {
        offset.push(total);
        total += n;
    }
    offset.push(total);
    let Ok(total_u32) = u32::try_from(total) else {
        return Tracks {
            tracks: Vec::new(),
            conflicting: 0,
        };
    };
    let mut parent: Vec<u32> = (0..total_u32).collect();
    // Position and level of every keypoint that takes part in a match.
    let mut info: Vec<Option<([f32; 2], u8)>> = vec![None; total];
    let id = |view: usize, kp: u32| -> Option<u32> {
        let base = *offset.get(view)?;
        let n = *keypoints_per_view.get(view)?;
        ((kp as usize) < n).then(|| (base + kp as usize) as u32)
    };
    for (k, pm) in matches.iter().enumerate() {
        if !use_pair(k) {
            continue;
        }
        for (m, ((kp, c), lv)) in pm
            .keypoints
            .iter()
            .zip(&pm.coords)
            .zip(pm.levels.iter().chain(std::iter::repeat(&[0u8, 0u8])))
            .enumerate()
        {
            if !use_match(k, m) {
                continue;
            }
            let (Some(a), Some(b)) = (id(pm.i, kp[0]), id(pm.j, kp[1])) else {
                continue;
            };
            if let Some(s) = info.get_mut(a as usize) {
                *s = Some(([c[0], c[1]], lv[0]));
            }
            if let Some(s) = info.get_mut(b as usize) {
                *s = Some(([c[2], c[3]], lv[1]));
            }
            union(&mut parent, a, b);
        }
    }
    // Components in the order of their smallest id (= root).
    let mut members: Vec<Vec<u32>> = Vec::new();
    let mut slot_of_root: Vec<u32> = vec![u32::MAX; total];
    for g in 0..total_u32 {
        if info.get(g as usize).is_none_or(Option::is_none) {
            continue;
        }
        let r = find(&mut parent, g);
        let Some(slot) = slot_of_root.get_mut(r as usize) else {
            continue;
        };
        if *slot == u32::MAX {
            *slot = members.len() as u32;
            members.push(Vec::new());
        }
        if let Some(list) = members.get_mut(*slot as usize) {
            list.push(g);
        }
    }
    let view_of = |g: u32| {
        offset
            .partition_point(|&o| o <= g as usize)
            .saturating_sub(1)
    };
    let mut tracks = Vec::new();
    let mut conflicting = 0;
    for list in members {
        if list.len() < 2 {
            continue;
        }
        // Ids grow with the view, so the list is sorted by view already.
        let mut observations = Vec::with_capacity(list.len());
        let mut conflict = false;
        for g in list {
            let view = view_of(g);
            if observations
                .last()
                .is_some_and(|o: &TrackObservation| o.view == view)
            {
                conflict = true;
                break;
            }
            let Some(Some((px, level))) = info.get(g as usize).copied() else {
                continue;
            };
            let base = offset.get(view).copied().unwrap_or(0);
            observations.push(TrackObservation {
                view,
                keypoint: (g as usize - base) as u32,
                px,
                level,
            });
        }
        if conflict {
            conflicting += 1;
        } else if observations.len() >= 2 {
            tracks.push(Track { observations });
        }
    }
    Tracks {
        tracks,
        conflicting,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(i: usize, j: usize, kps: &[[u32; 2]]) -> PairMatches {
        let coords = kps
            .iter()
            .map(|k| [k[0] as f32, i as f32, k[1] as f32, j as f32])
            .collect::<Vec<_>>();
        PairMatches {
            i,
            j,
            hand_rotation_deg: 10.0,
            raw_matches: kps.len(),
            levels: vec![[0, 1]; kps.len()],
            motion_inliers: vec![true; kps.len()],
            keypoints: kps.to_vec(),
            coords,
        }
    }

    #[test]
    fn chains_become_tracks_and_contradictions_are_dropped() {
        // View 0 kp 1 <-> view 1 kp 2 <-> view 2 kp 0: one track over three views.
        // View 0 kp 3 <-> view 1 kp 4, view 1 kp 4 <-> view 2 kp 5, view 0 kp 6 <-> view 2 kp 5:
        // view 0 holds kps 3 and 6 in one component: dropped.
        let m = vec![
            pair(0, 1, &[[1, 2], [3, 4]]),
            pair(1, 2, &[[2, 0], [4, 5]]),
            pair(0, 2, &[[6, 5]]),
        ];
        let t = build_tracks(&m, &[10, 10, 10], |_| true, |_, _| true);
        assert_eq!(t.conflicting, 1);
        assert_eq!(t.tracks.len(), 1);
        let obs = &t.tracks[0].observations;
        let ids: Vec<(usize, u32)> = obs.iter().map(|o| (o.view, o.keypoint)).collect();
        assert_eq!(ids, vec![(0, 1), (1, 2), (2, 0)]);
        assert_eq!(obs[0].px, [1.0, 0.0]);
        assert_eq!(obs[2].px, [0.0, 2.0]);
        // Pair 2 left out: the second component is no longer contradictory.
        let t = build_tracks(&m, &[10, 10, 10], |k| k != 2, |_, _| true);
        assert_eq!((t.tracks.len(), t.conflicting), (2, 0));
        // Out-of-range keypoints are ignored, not a panic.
        let bad = vec![pair(0, 1, &[[100, 2]])];
        assert!(
            build_tracks(&bad, &[10, 10], |_| true, |_, _| true)
                .tracks
                .is_empty()
        );
    }
}
