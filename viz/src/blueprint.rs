//! The default layout of the viewer: the 3D scene, the wrist camera (colour, depth), the
//! panoramic view, the matches, the time series, the task states and the log.
//!
//! ```text
//! +----------------------------+---------------------------------+
//! | 3D scene (map)             | wrist colour | depth | panoramic |
//! |                            +---------------------------------+
//! |                            | matches (a | b, inliers/rejected)|
//! +----------------------------+---------------------------------+
//! | plots: joints | ... | task states | metadata | log (robot_time)|
//! +----------------------------+---------------------------------+
//! ```
//!
//! The SDK's `rerun::blueprint` builder cannot set view properties (the 3D eye, the target
//! frame, per-entity visibility, the log's time column), so this module writes the blueprint
//! store itself, the way the SDK and the Python blueprint API do: containers at
//! `container/<id>`, views at `view/<id>` with their contents (`view/<id>/ViewContents`),
//! properties (`view/<id>/<Archetype>`) and entity overrides
//! (`view/<id>/ViewContents/overrides/<entity>/visualizers`), the viewport and the panels.
//! Ids are derived from the names ([`id_of`]), so the same recording always gets the same
//! blueprint.
//!
//! # The 3D view
//! Target frame `map` (the origin entity [`sink::WORLD`] is in `map` too); the eye at
//! [`Framing::eye_m`] looking at [`Framing::look_at_m`] (the caller frames the robot's start and
//! the wire); a 1 m ground grid; the simulator's truth ([`sink::SIM`]) and the calibration
//! views' depth captures ([`sink::CALIBRATION_CAPTURES`]) hidden (eye icon in the blueprint
//! panel to show them). The wrist depth image is not drawn in 3D (its points follow the camera;
//! the captures are in `map`).

use rerun::blueprint::components::{
    ActiveTab, ColumnShare, ContainerKind, IncludedContent, PanelState, PlayState, QueryExpression,
    RootContainer, RowShare, TimelineName, ViewClass,
};
use rerun::blueprint::datatypes::TimelineColumn;
use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg};
use rerun::external::re_sdk_types::blueprint::archetypes as bp;
use rerun::external::re_sdk_types::blueprint::components::TimelineColumn as TimelineColumnComponent;
use rerun::{AsComponents, RecordingStream, RecordingStreamBuilder};

use crate::{VizError, sink};

/// Where the 3D eye starts (m, `map`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Framing {
    /// Eye position.
    pub eye_m: [f32; 3],
    /// The point looked at (the orbit centre).
    pub look_at_m: [f32; 3],
}

impl Framing {
    /// An eye that sees every point of `points` (m, `map`): it looks at the centre of their
    /// bounding box from the side of `from_dir` (a horizontal unit-ish direction from the scene
    /// towards the eye), raised by 20 deg, far enough that the box's bounding sphere fits in
    /// a 60 deg cone (the 3D view is wider than high: the box's height, what limits, is less
    /// than its diagonal). `None` for no points.
    pub fn around(points: &[[f64; 3]], from_dir: [f64; 2]) -> Option<Self> {
        let first = points.first()?;
        let mut lo = *first;
        let mut hi = *first;
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let c = [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ];
        let half = [hi[0] - c[0], hi[1] - c[1], hi[2] - c[2]];
        let radius = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2])
            .sqrt()
            .max(1.0);
        // Bounding sphere seen under 60 deg: distance = r / sin(30 deg).
        let distance = radius / 30f64.to_radians().sin();
        let n = from_dir[0].hypot(from_dir[1]);
        let (dx, dy) = if n > 1e-9 {
            (from_dir[0] / n, from_dir[1] / n)
        } else {
            (-1.0, -1.0)
        };
        let elevation = 20f64.to_radians();
        let eye = [
            c[0] + distance * elevation.cos() * dx,
            c[1] + distance * elevation.cos() * dy,
            c[2] + distance * elevation.sin(),
        ];
        let f = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32];
        Some(Self {
            eye_m: f(eye),
            look_at_m: f(c),
        })
    }
}

/// A 128-bit id derived from `name` (two FNV-1a 64 hashes), with the version-4 and variant
/// bits set so it reads as an ordinary UUID.
pub fn id_of(name: &str) -> [u8; 16] {
    let a = crate::convert::fnv1a64(&["rodlog blueprint", name]);
    let b = crate::convert::fnv1a64(&[name, "rodlog blueprint"]);
    let mut bytes = [0u8; 16];
    bytes[..8].copy_from_slice(&a.to_be_bytes());
    bytes[8..].copy_from_slice(&b.to_be_bytes());
    bytes[6] = (bytes[6] & 0x0f) | 0x40;
    bytes[8] = (bytes[8] & 0x3f) | 0x80;
    bytes
}

/// `xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx` of `id`.
fn uuid_text(id: &[u8; 16]) -> String {
    let hex: String = id.iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &hex[..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..]
    )
}

/// One view of the layout.
struct View {
    name: &'static str,
    class: &'static str,
    origin: String,
    contents: Vec<String>,
    properties: Vec<(&'static str, Box<dyn AsComponents>)>,
    hidden: Vec<String>,
}

impl View {
    fn new(name: &'static str, class: &'static str, origin: &str) -> Self {
        Self {
            name,
            class,
            origin: origin.to_owned(),
            contents: vec!["$origin/**".to_owned()],
            properties: Vec::new(),
            hidden: Vec::new(),
        }
    }

    fn contents(mut self, queries: &[&str]) -> Self {
        self.contents = queries.iter().map(|q| (*q).to_owned()).collect();
        self
    }

    fn property(mut self, name: &'static str, archetype: impl AsComponents + 'static) -> Self {
        self.properties.push((name, Box::new(archetype)));
        self
    }

    fn path(&self) -> String {
        format!("view/{}", uuid_text(&id_of(self.name)))
    }
}

/// A container or a view.
enum Node {
    Container {
        name: &'static str,
        kind: ContainerKind,
        children: Vec<Node>,
        shares: Vec<f32>,
    },
    View(View),
}

impl Node {
    fn path(&self) -> String {
        match self {
            Node::Container { name, .. } => format!("container/{}", uuid_text(&id_of(name))),
            Node::View(v) => v.path(),
        }
    }
}

fn container(name: &'static str, kind: ContainerKind, shares: &[f32], children: Vec<Node>) -> Node {
    Node::Container {
        name,
        kind,
        children,
        shares: shares.to_vec(),
    }
}

/// Name of the root container (its id is the viewport's root).
const ROOT: &str = "root";

/// The layout (module docs).
fn layout(framing: Option<&Framing>) -> Node {
    let mut eye = bp::EyeControls3D::new();
    if let Some(f) = framing {
        eye = eye
            .with_position(f.eye_m)
            .with_look_target(f.look_at_m)
            .with_eye_up([0.0f32, 0.0, 1.0]);
    }
    let not_depth = format!("-{}", sink::WRIST_DEPTH);
    let mut scene = View::new("3D scene", "3D", sink::WORLD)
        .contents(&["$origin/**", not_depth.as_str()])
        .property(
            "SpatialInformation",
            bp::SpatialInformation::new(msgs::frames::MAP),
        )
        .property("EyeControls3D", eye)
        .property(
            "LineGrid3D",
            bp::LineGrid3D::new()
                .with_visible(true)
                .with_spacing(1.0f32),
        );
    scene.hidden.push(sink::SIM.to_owned());
    scene.hidden.push(sink::CALIBRATION_CAPTURES.to_owned());
    let image = |name: &'static str, entity: &str| {
        Node::View(View::new(name, "2D", entity).contents(&[entity]))
    };
    let wrist = container(
        "wrist",
        ContainerKind::Tabs,
        &[],
        vec![
            image("wrist colour", sink::WRIST_COLOR),
            image("wrist depth", sink::WRIST_DEPTH),
            image("panoramic", sink::PANORAMIC_COLOR),
        ],
    );
    let matches = Node::View(
        View::new("matches (inliers green, rejected red)", "2D", "matches")
            .contents(&["matches/**"]),
    );
    let series =
        |name: &'static str, origin: &str| Node::View(View::new(name, "TimeSeries", origin));
    let plots = container(
        "plots",
        ContainerKind::Tabs,
        &[],
        vec![
            series("joints (rad)", "plots/joints_rad"),
            Node::View(
                View::new("lift, clamp (m)", "TimeSeries", "plots/prismatic_m")
                    .contents(&["plots/prismatic_m/**", "plots/commands/**"]),
            ),
            series("wind (m/s)", "plots/wind"),
            series("illuminance (lx)", "plots/illuminance"),
            series("wrist light (0..1)", "plots/wrist_light"),
            series("calibration", "plots/calibration"),
            Node::View(View::new("task states", "StateTimeline", sink::STATES)),
            Node::View(View::new("metadata", "TextDocument", sink::METADATA)),
        ],
    );
    let log = Node::View(View::new("log", "TextLog", "log").property(
        "TextLogColumns",
        bp::TextLogColumns::new().with_timeline_columns([TimelineColumnComponent(
            TimelineColumn {
                visible: true.into(),
                timeline: sink::TIMELINE_LOG_TIME.into(),
            },
        )]),
    ));
    container(
        ROOT,
        ContainerKind::Vertical,
        &[0.68, 0.32],
        vec![
            container(
                "top",
                ContainerKind::Horizontal,
                &[0.58, 0.42],
                vec![
                    Node::View(scene),
                    container("right", ContainerKind::Vertical, &[], vec![wrist, matches]),
                ],
            ),
            container(
                "bottom",
                ContainerKind::Horizontal,
                &[0.55, 0.45],
                vec![plots, log],
            ),
        ],
    )
}

fn log_node(rec: &RecordingStream, node: &Node) -> Result<(), VizError> {
    match node {
        Node::Container {
            kind,
            children,
            shares,
            name,
        } => {
            for c in children {
                log_node(rec, c)?;
            }
            let mut arch = bp::ContainerBlueprint::new(*kind)
                .with_display_name(*name)
                .with_contents(
                    children
                        .iter()
                        .map(|c| IncludedContent(c.path().as_str().into())),
                );
            if !shares.is_empty() {
                let s = shares.iter().copied();
                arch = if *kind == ContainerKind::Vertical {
                    arch.with_row_shares(s.map(RowShare::from))
                } else {
                    arch.with_col_shares(s.map(ColumnShare::from))
                };
            }
            if *kind == ContainerKind::Tabs
                && let Some(first) = children.first()
            {
                arch = arch.with_active_tab(ActiveTab(first.path().as_str().into()));
            }
            rec.log(node.path(), &arch)?;
        }
        Node::View(v) => {
            let path = v.path();
            rec.log(
                format!("{path}/ViewContents"),
                &bp::ViewContents::new(
                    v.contents
                        .iter()
                        .map(|q| QueryExpression(q.as_str().into())),
                ),
            )?;
            rec.log(
                path.as_str(),
                &bp::ViewBlueprint::new(ViewClass(v.class.into()))
                    .with_display_name(v.name)
                    .with_space_origin(v.origin.as_str()),
            )?;
            for (name, arch) in &v.properties {
                rec.log(format!("{path}/{name}"), arch.as_ref())?;
            }
            for entity in &v.hidden {
                rec.log(
                    format!(
                        "{path}/ViewContents/overrides/{}/visualizers",
                        entity.trim_start_matches('/')
                    ),
                    &bp::EntityBehavior::new().with_visible(false),
                )?;
            }
        }
    }
    Ok(())
}

/// The blueprint messages of the default layout, as a blueprint store `blueprint_id`
/// (application [`crate::APPLICATION_ID`]).
///
/// # Errors
/// [`VizError::Rerun`] when the in-memory blueprint stream refuses a call.
pub fn blueprint_messages(
    blueprint_id: &str,
    framing: Option<&Framing>,
    follow: bool,
) -> Result<Vec<LogMsg>, VizError> {
    let (rec, storage) = RecordingStreamBuilder::new(crate::APPLICATION_ID)
        .recording_id(blueprint_id)
        .blueprint()
        .memory()?;
    rec.set_time_sequence("blueprint", 0);
    let root = layout(framing);
    log_node(&rec, &root)?;
    rec.log(
        "viewport",
        &bp::ViewportBlueprint::new()
            .with_root_container(RootContainer(id_of(ROOT).into()))
            .with_auto_layout(false)
            .with_auto_views(false),
    )?;
    rec.log(
        "blueprint_panel",
        &bp::PanelBlueprint::new().with_state(PanelState::Collapsed),
    )?;
    rec.log(
        "selection_panel",
        &bp::PanelBlueprint::new().with_state(PanelState::Collapsed),
    )?;
    rec.log(
        "time_panel",
        &bp::TimePanelBlueprint::new()
            .with_state(PanelState::Collapsed)
            .with_timeline(TimelineName::from(sink::TIMELINE_LOG_TIME))
            .with_play_state(if follow {
                PlayState::Following
            } else {
                PlayState::Paused
            }),
    )?;
    Ok(storage.take())
}

/// Sends the default blueprint on `rec` and makes it the active and default one.
///
/// `follow`: the time cursor follows the newest data (the end of a file; now, live).
///
/// # Errors
/// As [`blueprint_messages`].
pub fn send(
    rec: &RecordingStream,
    recording_id: &str,
    framing: Option<&Framing>,
    follow: bool,
) -> Result<(), VizError> {
    let msgs = blueprint_messages(&format!("{recording_id}-blueprint"), framing, follow)?;
    let Some(blueprint_id) = msgs.first().map(|m| m.store_id().clone()) else {
        return Ok(());
    };
    rec.send_blueprint(
        msgs,
        BlueprintActivationCommand {
            blueprint_id,
            make_active: true,
            make_default: true,
        },
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_stable_uuids() {
        let a = uuid_text(&id_of("3D scene"));
        assert_eq!(a, uuid_text(&id_of("3D scene")));
        assert_ne!(a, uuid_text(&id_of("log")));
        assert_eq!(a.len(), 36);
        assert_eq!(&a[14..15], "4", "{a}");
    }

    #[test]
    fn the_eye_sees_the_robot_and_the_wire() {
        let robot = [10.0, -1.3, 0.0];
        let wire = [12.0, 0.0, 3.7];
        let f = Framing::around(&[robot, wire], [-1.0, -1.0]).unwrap_or(Framing {
            eye_m: [0.0; 3],
            look_at_m: [0.0; 3],
        });
        assert_eq!(f.look_at_m, [11.0, -0.65, 1.85]);
        // From the south-west and above, farther than both points are from the centre.
        let d = |p: [f64; 3]| {
            let e = f.eye_m.map(f64::from);
            ((e[0] - p[0]).powi(2) + (e[1] - p[1]).powi(2) + (e[2] - p[2]).powi(2)).sqrt()
        };
        assert!(f.eye_m[0] < 11.0 && f.eye_m[1] < -0.65 && f.eye_m[2] > 1.85);
        assert!(d(robot) > 2.0 && d(wire) > 2.0);
        assert!(Framing::around(&[], [1.0, 0.0]).is_none());
    }

    #[test]
    fn the_blueprint_has_a_root_views_and_panels() -> Result<(), VizError> {
        let msgs = blueprint_messages("test-blueprint", None, true)?;
        assert!(msgs.len() > 1, "{}", msgs.len());
        Ok(())
    }
}
