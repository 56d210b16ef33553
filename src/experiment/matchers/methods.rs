//! Running each method on a pair (ours, and OpenCV through the reference venv) and scoring
//! its matches against the pair's truth.

use super::*;

// ---------------------------------------------------------------------------------------
// Running and judging the methods
// ---------------------------------------------------------------------------------------

/// What one method made of one pair, in plain coordinates (the adapter between
/// `calib::features` and the scoring).
#[derive(Clone, Debug)]
pub(super) struct MethodOutput {
    pub(super) keypoints_a: Vec<Keypoint>,
    pub(super) keypoints_b: Vec<Keypoint>,
    /// Number of keypoints detected in A (may exceed `keypoints_a.len()`).
    pub(super) n_keypoints_a: usize,
    /// Same for B.
    pub(super) n_keypoints_b: usize,
    /// Accepted matches (after the method's own filter).
    pub(super) accepted: Vec<Match>,
    /// Wall time detect + match + filter, ms (NaN when not measured).
    pub(super) time_ms: f64,
}

impl MethodOutput {
    fn ends(&self, m: &Match) -> Option<((f64, f64), (f64, f64))> {
        let a = self.keypoints_a.get(m.query as usize)?;
        let b = self.keypoints_b.get(m.train as usize)?;
        Some((
            (f64::from(a.x), f64::from(a.y)),
            (f64::from(b.x), f64::from(b.y)),
        ))
    }
}

/// A row of the tables: a method with its parameters.
pub(super) struct Variant {
    pub(super) name: String,
    pub(super) method: MatchMethod,
    pub(super) params: MatchImagesParams,
}

/// Every available method with its defaults, then [`RETAIN_BEST_METHOD`]: orb-gms with
/// OpenCV's keypoint selection instead of the quadtree, to separate the effect of the
/// selection from that of the rest of the pipeline in the comparison with OpenCV.
pub(super) fn variants() -> Vec<Variant> {
    let mut v: Vec<Variant> = available_methods()
        .into_iter()
        .map(|m| Variant {
            name: m.name().to_owned(),
            method: m,
            params: MatchImagesParams::for_method(m),
        })
        .collect();
    let mut params = MatchImagesParams::for_method(MatchMethod::OrbGms);
    params.orb.distribution = KeypointDistribution::RetainBest;
    v.push(Variant {
        name: RETAIN_BEST_METHOD.to_owned(),
        method: MatchMethod::OrbGms,
        params,
    });
    v
}

/// The methods of this build (module docs).
pub fn available_methods() -> Vec<MatchMethod> {
    CANDIDATE_METHODS
        .iter()
        .filter_map(|name| name.parse::<MatchMethod>().ok())
        .fold(Vec::new(), |mut v, m| {
            if !v.contains(&m) {
                v.push(m);
            }
            v
        })
}

pub(super) fn run_method(
    pair: &ImagePair,
    variant: &Variant,
) -> Result<MethodOutput, FeatureError> {
    let a = GrayView::from_image(&pair.a);
    let b = GrayView::from_image(&pair.b);
    let r = match_images(&a, &b, variant.method, &variant.params)?;
    let accepted: Vec<Match> = r.inlier_matches().copied().collect();
    let t = r.timings;
    Ok(MethodOutput {
        n_keypoints_a: r.features_a.keypoints.len(),
        n_keypoints_b: r.features_b.keypoints.len(),
        keypoints_a: r.features_a.keypoints,
        keypoints_b: r.features_b.keypoints,
        accepted,
        time_ms: t.detect_ms + t.match_ms + t.filter_ms,
    })
}

/// OpenCV's ORB + BF + GMS on the pair through `opencv_ref.py` (module docs).
pub(super) fn run_opencv(
    pair: &ImagePair,
    python: &Path,
    script: &Path,
    tmp: &Path,
) -> Result<MethodOutput> {
    let (pa, pb) = (tmp.join("a.png"), tmp.join("b.png"));
    pair.a.save(&pa).context("writing the reference input")?;
    pair.b.save(&pb).context("writing the reference input")?;
    let out = Command::new(python)
        .arg(script)
        .arg("orb-gms")
        .arg(&pa)
        .arg(&pb)
        .args(["--features", &FEATURES.to_string()])
        .output()
        .with_context(|| format!("running {}", script.display()))?;
    if !out.status.success() {
        bail!(
            "opencv_ref.py failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).context("parsing opencv_ref.py output")?;
    let count = |k: &str| v.get(k).and_then(serde_json::Value::as_u64).unwrap_or(0) as usize;
    let rows = v
        .get("matches")
        .and_then(serde_json::Value::as_array)
        .context("opencv_ref.py output has no matches")?;
    // Only the matched keypoints come back: rebuild one keypoint per match end.
    let kp = |x: f64, y: f64| Keypoint {
        x: x as f32,
        y: y as f32,
        level: 0,
        angle_rad: 0.0,
        response: 0.0,
        size: 31.0,
    };
    let mut o = MethodOutput {
        n_keypoints_a: 0,
        n_keypoints_b: 0,
        keypoints_a: Vec::with_capacity(rows.len()),
        keypoints_b: Vec::with_capacity(rows.len()),
        accepted: Vec::with_capacity(rows.len()),
        time_ms: f64::NAN,
    };
    for (i, r) in rows.iter().enumerate() {
        let f = |k: usize| r.get(k).and_then(serde_json::Value::as_f64);
        let (Some(xa), Some(ya), Some(xb), Some(yb)) = (f(0), f(1), f(3), f(4)) else {
            bail!("malformed match row {i} from opencv_ref.py");
        };
        o.keypoints_a.push(kp(xa, ya));
        o.keypoints_b.push(kp(xb, yb));
        o.accepted.push(Match {
            query: i as u32,
            train: i as u32,
            distance: 0,
        });
    }
    // Only the match ends were rebuilt: report the detector's counts.
    o.n_keypoints_a = count("keypoints_a");
    o.n_keypoints_b = count("keypoints_b");
    Ok(o)
}

/// The measures of one (pair, method); serialised into results.json.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct PairScore {
    /// Pair set.
    pub set: PairSet,
    /// Pair label.
    pub pair: String,
    /// Trial seed of the pair.
    pub seed: u64,
    /// Method name.
    pub method: String,
    /// `None` when the method answered; the reason when it refused.
    pub refused: Option<String>,
    /// Keypoints in A.
    pub keypoints_a: usize,
    /// Keypoints in B.
    pub keypoints_b: usize,
    /// Accepted matches.
    pub matches: usize,
    /// Matches the geometry could judge.
    pub judged: usize,
    /// Matches the geometry confirms.
    pub true_matches: usize,
    /// `true_matches / judged` (NaN -> null when nothing was judged).
    pub true_rate: f64,
    /// Fraction of the 8x8 grid cells over A holding a true match.
    pub spread: f64,
    /// Shecar only: fraction of all accepted matches within 3 px of their epipolar line.
    pub epipolar_rate: Option<f64>,
    /// Detect + match + filter, ms (NaN -> null when not measured).
    pub time_ms: f64,
}

/// Judges `out` on `pair`; also returns the per-match verdicts (for the pictures).
pub(super) fn score(pair: &ImagePair, method: &str, out: &MethodOutput) -> (PairScore, Vec<bool>) {
    let (w, h) = (f64::from(pair.a.width()), f64::from(pair.a.height()));
    let mut cells = [[false; SPREAD_GRID]; SPREAD_GRID];
    let (mut judged, mut true_n, mut epi_ok, mut epi_n) = (0usize, 0usize, 0usize, 0usize);
    let mut flags = Vec::with_capacity(out.accepted.len());
    for m in &out.accepted {
        let Some((a, b)) = out.ends(m) else {
            flags.push(false);
            continue;
        };
        let verdict = pair.truth.judge(a, b);
        if verdict != Verdict::Unjudged {
            judged += 1;
        }
        if verdict == Verdict::True {
            true_n += 1;
            let cx = ((a.0 / w * SPREAD_GRID as f64) as usize).min(SPREAD_GRID - 1);
            let cy = ((a.1 / h * SPREAD_GRID as f64) as usize).min(SPREAD_GRID - 1);
            if let Some(c) = cells.get_mut(cy).and_then(|r| r.get_mut(cx)) {
                *c = true;
            }
        }
        if let Some(ok) = pair.truth.epipolar_ok(a, b) {
            epi_n += 1;
            epi_ok += usize::from(ok);
        }
        flags.push(verdict == Verdict::True);
    }
    let covered = cells.iter().flatten().filter(|c| **c).count();
    let ratio = |k: usize, n: usize| {
        if n == 0 {
            f64::NAN
        } else {
            k as f64 / n as f64
        }
    };
    (
        PairScore {
            set: pair.set,
            pair: pair.label.clone(),
            seed: pair.seed,
            method: method.to_owned(),
            refused: None,
            keypoints_a: out.n_keypoints_a,
            keypoints_b: out.n_keypoints_b,
            matches: out.accepted.len(),
            judged,
            true_matches: true_n,
            true_rate: ratio(true_n, judged),
            spread: covered as f64 / (SPREAD_GRID * SPREAD_GRID) as f64,
            epipolar_rate: matches!(pair.truth, Truth::Board(_)).then(|| ratio(epi_ok, epi_n)),
            time_ms: out.time_ms,
        },
        flags,
    )
}

pub(super) fn refused_score(pair: &ImagePair, method: &str, reason: String) -> PairScore {
    PairScore {
        set: pair.set,
        pair: pair.label.clone(),
        seed: pair.seed,
        method: method.to_owned(),
        refused: Some(reason),
        keypoints_a: 0,
        keypoints_b: 0,
        matches: 0,
        judged: 0,
        true_matches: 0,
        true_rate: f64::NAN,
        spread: 0.0,
        epipolar_rate: None,
        time_ms: f64::NAN,
    }
}

/// The match picture of one pair and method: accepted matches only, green when the geometry
/// confirms them, red when it does not or cannot judge them.
pub(super) fn draw(
    pair: &ImagePair,
    out: &MethodOutput,
    flags: &[bool],
    path: &Path,
) -> Result<()> {
    let a = GrayView::from_image(&pair.a);
    let b = GrayView::from_image(&pair.b);
    let img = calib::features::draw::draw_matches(
        &a,
        &b,
        &out.keypoints_a,
        &out.keypoints_b,
        &out.accepted,
        flags,
    );
    img.save(path)
        .with_context(|| format!("writing {}", path.display()))
}
