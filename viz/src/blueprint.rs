//! The default layout of the viewer: the 3D scene, the wrist camera (colour, depth), the
//! panoramic view, the matches, the time series and the log.
//!
//! ```text
//! +----------------------------+---------------------------------+
//! | 3D scene (world, map)      | wrist colour | depth | panoramic |
//! |                            +---------------------------------+
//! |                            | matches (a | b, inliers/rejected)|
//! +----------------------------+---------------------------------+
//! | plots: joints | wind | light | calibration | log            |
//! +----------------------------+---------------------------------+
//! ```

use rerun::blueprint::components::PlayState;
use rerun::blueprint::{
    Blueprint, Horizontal, Spatial2DView, Spatial3DView, Tabs, TextDocumentView, TextLogView,
    TimePanel, TimeSeriesView, Vertical,
};

use crate::sink;

/// The default blueprint (sent with every recording stream [`crate::stream`] makes).
pub fn default_blueprint() -> Blueprint {
    let scene = Spatial3DView::new("3D scene")
        .with_origin(sink::WORLD)
        .with_contents(["world/**"]);
    let wrist = Tabs::new([
        Spatial2DView::new("wrist colour")
            .with_origin(sink::WRIST_COLOR)
            .with_contents([sink::WRIST_COLOR])
            .into(),
        Spatial2DView::new("wrist depth")
            .with_origin(sink::WRIST_DEPTH)
            .with_contents([sink::WRIST_DEPTH])
            .into(),
        Spatial2DView::new("panoramic")
            .with_origin(sink::PANORAMIC_COLOR)
            .with_contents([sink::PANORAMIC_COLOR])
            .into(),
    ]);
    let matches = Spatial2DView::new("matches (inliers green, rejected red)")
        .with_origin("matches")
        .with_contents(["matches/**"]);
    let plots = Tabs::new([
        TimeSeriesView::new("joints (rad)")
            .with_origin("plots/joints_rad")
            .into(),
        TimeSeriesView::new("lift, clamp (m)")
            .with_origin("plots/prismatic_m")
            .with_contents(["plots/prismatic_m/**", "plots/commands/**"])
            .into(),
        TimeSeriesView::new("wind (m/s)")
            .with_origin("plots/wind")
            .into(),
        TimeSeriesView::new("illuminance (lx)")
            .with_origin("plots/illuminance")
            .into(),
        TimeSeriesView::new("calibration")
            .with_origin("plots/calibration")
            .into(),
        TextDocumentView::new("metadata")
            .with_origin(sink::METADATA)
            .into(),
    ]);
    let log = TextLogView::new("log").with_origin("log");
    Blueprint::new(
        Vertical::new([
            Horizontal::new([
                scene.into(),
                Vertical::new([wrist.into(), matches.into()]).into(),
            ])
            .with_column_shares([0.55, 0.45])
            .into(),
            Horizontal::new([plots.into(), log.into()])
                .with_column_shares([0.55, 0.45])
                .into(),
        ])
        .with_row_shares([0.68, 0.32]),
    )
    .with_auto_views(false)
    // On the robot clock, following the newest data: a live run shows now, a file its end.
    .with_time_panel(
        TimePanel::new()
            .with_timeline(sink::TIMELINE_LOG_TIME)
            .with_play_state(PlayState::Following),
    )
}
