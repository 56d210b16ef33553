//! [`TopicSource`]: one DDS subscription as a [`LiveSource`]: it waits for samples on its own
//! thread, stamps each with the robot clock on arrival, converts it through the remap and
//! pushes it with the bytes to record. [`ClockSource`]: the graph's `/clock`, which drives the
//! robot clock under `use_sim_time`.
//!
//! A transport at the edge: it converts, stamps and counts, nothing else. The
//! payload recorded is the payload received whenever the remap changes nothing.

use std::sync::Arc;
use std::time::Duration;

use msgs::drivers::DriverError;
use msgs::rcl_interfaces::Log;
use msgs::{Msg, RobotTime};
use recorder::{Channel, Envelope, Feed, LiveSource, Pushed};
use ros2::{Remap, Route, Subscription};

/// How long one wait for a sample lasts before the stop flag is checked again.
pub const POLL: Duration = Duration::from_millis(50);

/// One subscription, its route and the remap it converts through.
pub struct TopicSource {
    name: String,
    subscription: Subscription,
    route: Route,
    remap: Arc<Remap>,
    channel: Arc<Channel>,
    log_channel: Arc<Channel>,
    hook: Option<Hook>,
}

/// Called with every message a [`TopicSource`] decodes and its robot time of arrival (the
/// safety monitor's view of `/joint_states`, the camera and the e-stop).
pub type Hook = Arc<dyn Fn(&Msg, RobotTime) + Send + Sync>;

impl std::fmt::Debug for TopicSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TopicSource")
            .field("route", &self.route)
            .finish_non_exhaustive()
    }
}

impl TopicSource {
    /// A source of `route` over `subscription` (subscribed to `route.vendor`).
    #[must_use]
    pub fn new(subscription: Subscription, route: Route, remap: Arc<Remap>) -> Self {
        let channel = Channel::known(route.rodlog, &route.producer, route.type_name);
        let log_channel = Channel::known(
            msgs::topics::ROSOUT,
            &route.producer,
            <Log as msgs::RosMessage>::TYPE_NAME,
        );
        Self {
            name: route.vendor.clone(),
            subscription,
            route,
            remap,
            channel,
            log_channel,
            hook: None,
        }
    }

    /// Calls `hook` with every message decoded, right after it was stamped.
    #[must_use]
    pub fn with_hook(mut self, hook: Hook) -> Self {
        self.hook = Some(hook);
        self
    }

    /// The envelope of one received payload: converted, or undecoded (given to no stage,
    /// recorded as it came) with the reason.
    fn envelope(&self, cdr: Vec<u8>, t: RobotTime) -> (Envelope, Option<String>) {
        match self.remap.convert(&self.route, &cdr) {
            Ok((msg, converted)) => (
                Envelope {
                    channel: Arc::clone(&self.channel),
                    log_time: t,
                    publish_time: t,
                    msg: Some(msg),
                    cdr: converted.unwrap_or(cdr),
                },
                None,
            ),
            Err(e) => (
                Envelope {
                    channel: Arc::clone(&self.channel),
                    log_time: t,
                    publish_time: t,
                    msg: None,
                    cdr,
                },
                Some(e.to_string()),
            ),
        }
    }
}

impl LiveSource for TopicSource {
    fn name(&self) -> &str {
        &self.name
    }

    fn run(mut self: Box<Self>, feed: Feed) -> Result<(), DriverError> {
        let topic = self.route.rodlog;
        let counters = self.subscription.counters();
        let mut lost_seen = 0u64;
        let mut warned = false;
        while !feed.stopped() {
            let received =
                self.subscription
                    .recv_timeout(POLL)
                    .map_err(|e| DriverError::Fault {
                        device: self.name.clone(),
                        now: feed.now(),
                        reason: e.to_string(),
                    })?;
            let lost = counters.lost();
            if lost > lost_seen {
                feed.counts().update(topic, |c| c.lost += lost - lost_seen);
                lost_seen = lost;
            }
            let Some(r) = received else {
                continue;
            };
            let t = feed.now();
            let (env, problem) = self.envelope(r.cdr, t);
            if let (Some(hook), Some(msg)) = (&self.hook, &env.msg) {
                hook(msg, t);
            }
            if let Some(reason) = problem {
                feed.counts().update(topic, |c| c.undecodable += 1);
                if !warned {
                    // The first one is explained on /rosout; later ones are counted.
                    warned = true;
                    let log = recorder::runner::rosout(
                        &self.route.producer,
                        t,
                        Log::ERROR,
                        format!("{reason} (recorded undecoded; later ones only counted)"),
                    );
                    if let Ok(e) = Envelope::encode(Arc::clone(&self.log_channel), t, t, log) {
                        let _ = feed.push(e);
                    }
                }
            }
            if feed.push(env) == Pushed::Closed {
                break;
            }
        }
        Ok(())
    }
}

/// The graph's `/clock` (`rosgraph_msgs/msg/Clock`): every message advances the run's
/// external robot clock. Not recorded as a message: every log time of the recording is a
/// `/clock` value, and the runtime feeds the stages their own `/clock` every 100 ms of it.
pub struct ClockSource {
    subscription: Subscription,
}

impl std::fmt::Debug for ClockSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ClockSource").finish_non_exhaustive()
    }
}

impl ClockSource {
    /// A source over a `/clock` subscription.
    #[must_use]
    pub fn new(subscription: Subscription) -> Self {
        Self { subscription }
    }
}

impl LiveSource for ClockSource {
    fn name(&self) -> &str {
        msgs::topics::CLOCK
    }

    fn run(mut self: Box<Self>, feed: Feed) -> Result<(), DriverError> {
        while !feed.stopped() {
            let received =
                self.subscription
                    .recv_timeout(POLL)
                    .map_err(|e| DriverError::Fault {
                        device: msgs::topics::CLOCK.to_owned(),
                        now: feed.now(),
                        reason: e.to_string(),
                    })?;
            let Some(r) = received else {
                continue;
            };
            match Msg::decode(
                <msgs::rosgraph_msgs::Clock as msgs::RosMessage>::TYPE_NAME,
                &r.cdr,
            ) {
                Ok(Msg::Clock(c)) => match RobotTime::from_ros(c.clock) {
                    Ok(t) => feed.clock().advance_to(t),
                    Err(_) => feed
                        .counts()
                        .update(msgs::topics::CLOCK, |c| c.undecodable += 1),
                },
                _ => feed
                    .counts()
                    .update(msgs::topics::CLOCK, |c| c.undecodable += 1),
            }
        }
        Ok(())
    }
}
