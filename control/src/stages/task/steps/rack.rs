//! `rack` (remove): the rod over the rack, into its holders (where the stored rod was seen
//! by the hang, or where `capture_empty_rack` measured the rack), and the empty gripper backs
//! off; the rod is then on the rack. The place beside the rack where the rod waits is tried
//! at a few distances and heights, each in the arm's IK branches ([`OUTSIDE_OFFSETS`]).

use nalgebra::Vector3;

use crate::motion::planner;
use crate::motion::trajectory::DEFAULT_DT_NS;
use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::memory::Rod;
use crate::tasks::poses;
use crate::tasks::site::RACK_HOLDERS;

/// The step's event name.
pub(crate) const NAME: &str = "rack";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

/// Where the rod waits beside the rack before going in, tried in turn with the arm's IK
/// branches: (factor on [`TaskConfig::rack_exit_m`](crate::stages::task::TaskConfig::rack_exit_m)
/// out from the holders, m higher). A rack placed a few cm off or turned a few degrees can
/// bring the upper arm onto its base plate, or the handle onto a holder, on the way there.
pub(crate) const OUTSIDE_OFFSETS: [(f64, f64); 4] =
    [(1.0, 0.0), (1.5, 0.0), (1.0, 0.1), (0.7, 0.0)];

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let config = &task.config;
    let q = p.q()?;
    let lift = p.lift()?;
    let stored = p.stored_rod_in_base()?;
    let rack = p.base_from_map()? * config.site.map_from_rack;
    let grasp = poses::grasp_tool0(&stored);
    let above = poses::shifted(
        &grasp,
        &rack,
        &Vector3::new(0.0, 0.0, config.rack_lift_out_m),
    );
    let outsides: Vec<_> = OUTSIDE_OFFSETS
        .iter()
        .map(|&(exit, rise_m)| {
            poses::shifted(
                &above,
                &rack,
                &Vector3::new(0.0, -config.rack_exit_m * exit, rise_m),
            )
        })
        .collect();
    let world = p.world(lift)?;
    let mut world_in = world.clone();
    for holder in RACK_HOLDERS {
        for part in ["rod_handle", "rod_shaft", "rod_head"] {
            world_in = world_in.allowing(part, holder);
        }
    }
    let world_rack = p
        .world_for(lift, Rod::OnRack)?
        .allowing("tool", "stored_rod_handle")
        .allowing("arm_wrist3_link", "stored_rod_handle");
    p.first_plannable(lift, &outsides, &q, |q_out| {
        let to_outside = p.plan_move(&world, lift, &q, q_out, "rod over the rack")?;
        let mut via = p.line_waypoints(lift, q_out, &above)?;
        let last = via.last().copied().unwrap_or(*q_out);
        via.extend(p.line_waypoints(lift, &last, &grasp)?);
        let into = p.plan(&world_in, lift, q_out, &via, "rod into the rack")?;
        // Release: the tool backs off the handle; the rod stays in the rack.
        let q_in = via.last().copied().unwrap_or(*q_out);
        let back = poses::along_own_z(&grasp, -config.pregrasp_m);
        let line = p.line_waypoints(lift, &q_in, &back)?;
        // The released rod stays in the rack: the empty arm backs off.
        let release = planner::plan_through(
            p.empty_arm(),
            &world_rack,
            lift,
            &q_in,
            &line,
            DEFAULT_DT_NS,
        )
        .map_err(|e| Stop::refused("collision", format!("release at the rack: {e}")))?;
        Ok(vec![
            p.arm_action(&to_outside, "rod over the rack"),
            p.arm_action(&into, "rod into the rack"),
            p.arm_action(&release, "release the rod"),
        ])
    })
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.memory.rod = Rod::OnRack;
    Ok(Next::Following)
}
