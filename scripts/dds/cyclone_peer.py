#!/usr/bin/env python3
"""An independent ROS 2 peer over Eclipse Cyclone DDS (Python binding `cyclonedds`), for the
interop tests and benchmarks of the `ros2` crate (ros2/tests/, ros2/examples/stream_bench.rs).

ROS 2 on DDS: topic `rt/<name>`, type `<pkg>::msg::dds_::<Type>_`, XCDR1 little-endian.
Traffic stays on the loopback interface (no multicast, unicast discovery to 127.0.0.1, what
ROS_LOCALHOST_ONLY=1 configures for rmw_cyclonedds) unless --any-interface is given.

Modes (domain from --domain, else ROS_DOMAIN_ID, else 0):
  pub-joint-states  JointState on /joint_states (reliable by default) at --rate Hz
  pub-image         Image (rgb8 or 32FC1) on --topic (best-effort by default) at --rate Hz
  sub               subscribe to --topic (--type joint_state|image|tf) and dump what it
                    received as JSON (--out, default stdout): field values, source stamps
  bench-pub         colour + depth images at --rate and JointState at --js-rate for
                    --duration s, pre-serialised once (only the stamp is patched per message)
                    and written as raw CDR, so the Python serialiser is not the bottleneck
  bench-sub         count and time what arrives on the three bench topics (raw, no decoding)
  serve-trigger     a std_srvs/Trigger server on service --topic, as rmw_cyclonedds maps it:
                    rq/<service>Request and rr/<service>Reply, each payload starting with the
                    16-byte header {uint64 client_id, int64 sequence} the reply echoes
  robot             a robot for `rodlog record --ros2 --allow-motion` to drive: publishes
                    /joint_states (rodlog's arm joints) at --js-rate Hz, listens on every command
                    topic (raw CDR kept), optionally serves a FollowJointTrajectory action
                    (--action), publishes a driver status (--status-topic/-type/-field/-value),
                    an /estop after N commands (--estop-after), stops its joint states after N
                    commands (--stop-js-after), and watches the graph for writers on the
                    command topics (Cyclone's built-in DCPSPublication topic) for --duration s
  sim-client        a client of `rodlog sim --ros2`: wait for --count JointStates on
                    /joint_states, publish one std_msgs/Empty on /camera/trigger (reliable),
                    then wait for the wrist image on /camera/color/image_raw; report both

Publishers wait up to --wait-match s for --readers matched readers, then --settle s (the
readers must match the writer too), before the first message, and --linger s after the last
(for reliable delivery and late joiners).
"""

import argparse
import json
import os
import resource
import struct
import sys
import time
from dataclasses import dataclass, field
from typing import List

# A 4 MB image arrives as one burst of fragments: with Cyclone's default 1 MB socket receive
# buffer most of them are dropped (measured: 1-2 of 50 reliable 4 MB images arrived from
# RustDDS); 4 MB is this machine's net.core.rmem_max.
BUFFERS = '<Internal><SocketReceiveBufferSize min="4MB"/></Internal>'
LOCALHOST_URI = (
    "<CycloneDDS><Domain><General><Interfaces>"
    '<NetworkInterface name="lo" multicast="false"/>'
    "</Interfaces><AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>64</MaxAutoParticipantIndex>"
    '<Peers><Peer address="127.0.0.1"/></Peers></Discovery>'
    + BUFFERS
    + "</Domain></CycloneDDS>"
)
ANY_INTERFACE_URI = "<CycloneDDS><Domain>" + BUFFERS + "</Domain></CycloneDDS>"


def parse_args():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mode", choices=["pub-joint-states", "pub-image", "sub", "bench-pub", "bench-sub",
                                   "serve-trigger", "sim-client", "robot"])
    p.add_argument("--domain", type=int, default=None)
    p.add_argument("--topic", default=None, help="ROS topic name, e.g. /joint_states")
    p.add_argument("--type", default="joint_state", choices=["joint_state", "image", "tf", "task_event"])
    p.add_argument("--reliability", default=None, choices=["reliable", "best-effort"])
    p.add_argument("--durability", default="volatile", choices=["volatile", "transient-local"])
    p.add_argument("--depth", type=int, default=10, help="keep-last history depth")
    p.add_argument("--count", type=int, default=10)
    p.add_argument("--rate", type=float, default=10.0)
    p.add_argument("--js-rate", type=float, default=100.0)
    p.add_argument("--duration", type=float, default=30.0)
    p.add_argument("--width", type=int, default=64)
    p.add_argument("--height", type=int, default=48)
    p.add_argument("--encoding", default="rgb8", choices=["rgb8", "32FC1"])
    p.add_argument("--timeout", type=float, default=20.0, help="sub: give up after this many s")
    p.add_argument("--wait-match", type=float, default=15.0)
    p.add_argument("--readers", type=int, default=1)
    p.add_argument("--linger", type=float, default=1.0)
    p.add_argument("--settle", type=float, default=1.0,
                   help="s to wait after the readers matched: discovery is two-way, and a "
                   "reader drops samples of a writer it has not matched yet")
    p.add_argument("--out", default=None)
    p.add_argument("--raw", action="store_true",
                   help="sub: record sizes and times only (no decoding); pub-image: serialise "
                   "once and patch only the stamp per message (the pixels repeat)")
    p.add_argument("--any-interface", action="store_true", help="default Cyclone networking")
    p.add_argument("--action", default=None, help="robot: serve FollowJointTrajectory here")
    p.add_argument("--status-topic", default=None)
    p.add_argument("--status-type", default="aubo_dashboard_msgs/msg/SafetyMode")
    p.add_argument("--status-field", default="uint8", choices=["uint8", "int8", "int32"])
    p.add_argument("--status-value", type=int, default=1)
    p.add_argument("--estop-after", type=int, default=0, help="robot: /estop after N commands")
    p.add_argument("--stop-js-after", type=int, default=0,
                   help="robot: stop /joint_states after N commands")
    return p.parse_args()


ARGS = parse_args()
os.environ["CYCLONEDDS_URI"] = ANY_INTERFACE_URI if ARGS.any_interface else LOCALHOST_URI

from cyclonedds.core import Policy, Qos  # noqa: E402 (after CYCLONEDDS_URI is set)
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl.types import array, float64, int8, int32, int64, sequence, uint8, uint16, uint32, uint64  # noqa: E402
from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds._clayer import ddspy_take, ddspy_write  # noqa: E402
from cyclonedds.core import InstanceState, SampleState, ViewState  # noqa: E402


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: uint32
    width: uint32
    encoding: str
    is_bigendian: uint8
    step: uint32
    data: sequence[uint8]


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


# rmw_cyclonedds writes its request header in front of the fields, so on the wire the service
# types are these (Cyclone checks written bytes against the type, so the header must be in it).
@dataclass
class TriggerRequest(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    client_id: uint64
    sequence: int64
    structure_needs_at_least_one_member: uint8


@dataclass
class TriggerResponse(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    client_id: uint64
    sequence: int64
    success: bool
    message: str


@dataclass
class Empty(IdlStruct, typename="std_msgs::msg::dds_::Empty_"):
    structure_needs_at_least_one_member: uint8


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32
    nanosec: uint32


@dataclass
class JointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectoryPoint_"):
    positions: sequence[float64]
    velocities: sequence[float64]
    accelerations: sequence[float64]
    effort: sequence[float64]
    time_from_start: Duration


@dataclass
class JointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectory_"):
    header: Header
    joint_names: sequence[str]
    points: sequence[JointTrajectoryPoint]


@dataclass
class Float64(IdlStruct, typename="std_msgs::msg::dds_::Float64_"):
    data: float64


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header
    pose: Pose


@dataclass
class ClampCommand(IdlStruct, typename="rodlog_msgs::msg::dds_::ClampCommand_"):
    header: Header
    action: uint8
    max_torque_nm: float64


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3


@dataclass
class MultiDOFJointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::MultiDOFJointTrajectoryPoint_"):
    transforms: sequence[Transform]
    velocities: sequence[Twist]
    accelerations: sequence[Twist]
    time_from_start: Duration


@dataclass
class MultiDOFJointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::MultiDOFJointTrajectory_"):
    header: Header
    joint_names: sequence[str]
    points: sequence[MultiDOFJointTrajectoryPoint]


@dataclass
class JointTolerance(IdlStruct, typename="control_msgs::msg::dds_::JointTolerance_"):
    name: str
    position: float64
    velocity: float64
    acceleration: float64


@dataclass
class JointComponentTolerance(IdlStruct, typename="control_msgs::msg::dds_::JointComponentTolerance_"):
    joint_name: str
    component: uint16
    position: float64
    velocity: float64
    acceleration: float64


@dataclass
class FJTGoal(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_Goal_"):
    trajectory: JointTrajectory
    multi_dof_trajectory: MultiDOFJointTrajectory
    path_tolerance: sequence[JointTolerance]
    component_path_tolerance: sequence[JointComponentTolerance]
    goal_tolerance: sequence[JointTolerance]
    component_goal_tolerance: sequence[JointComponentTolerance]
    goal_time_tolerance: Duration


@dataclass
class UUID(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
    uuid: array[uint8, 16]


# The action's services as rmw_cyclonedds puts them on the wire: {client_id, sequence} first.
@dataclass
class SendGoalRequest(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_SendGoal_Request_"):
    client_id: uint64
    sequence: int64
    goal_id: UUID
    goal: FJTGoal


@dataclass
class SendGoalResponse(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_SendGoal_Response_"):
    client_id: uint64
    sequence: int64
    accepted: bool
    stamp: Time


@dataclass
class GetResultRequest(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_GetResult_Request_"):
    client_id: uint64
    sequence: int64
    goal_id: UUID


@dataclass
class FJTResult(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_Result_"):
    error_code: int32
    error_string: str


@dataclass
class GetResultResponse(IdlStruct, typename="control_msgs::action::dds_::FollowJointTrajectory_GetResult_Response_"):
    client_id: uint64
    sequence: int64
    status: int8
    result: FJTResult


@dataclass
class GoalInfo(IdlStruct, typename="action_msgs::msg::dds_::GoalInfo_"):
    goal_id: UUID
    stamp: Time


@dataclass
class CancelGoalRequest(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Request_"):
    client_id: uint64
    sequence: int64
    goal_info: GoalInfo


@dataclass
class CancelGoalResponse(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Response_"):
    client_id: uint64
    sequence: int64
    return_code: int8
    goals_canceling: sequence[GoalInfo]


@dataclass
class TaskEvent(IdlStruct, typename="rodlog_msgs::msg::dds_::TaskEvent_"):
    header: Header
    task: str
    state: str
    kind: uint8
    reason_code: str
    text: str


TYPES = {"joint_state": JointState, "image": Image, "tf": TFMessage, "task_event": TaskEvent}
COMMAND_TOPICS = [("/arm/joint_trajectory", JointTrajectory), ("/lift/command", Float64),
                  ("/base/goal", PoseStamped), ("/clamp/command", ClampCommand),
                  ("/camera/trigger", Empty)]
RODLOG_ARM_JOINTS = ["arm_shoulder_joint", "arm_upperarm_joint", "arm_forearm_joint",
                     "arm_wrist1_joint", "arm_wrist2_joint", "arm_wrist3_joint"]
JOINT_NAMES = ["shoulder_joint", "upper_arm_joint", "fore_arm_joint", "wrist1_joint", "wrist2_joint", "wrist3_joint"]


def dds_topic(name: str) -> str:
    return "rt" + name if name.startswith("/") else "rt/" + name


def qos(reliability: str, durability: str, depth: int) -> Qos:
    rel = (
        Policy.Reliability.Reliable(max_blocking_time=1_000_000_000)
        if reliability == "reliable"
        else Policy.Reliability.BestEffort
    )
    dur = Policy.Durability.TransientLocal if durability == "transient-local" else Policy.Durability.Volatile
    return Qos(rel, dur, Policy.History.KeepLast(depth))


def now_ns() -> int:
    return time.time_ns()


def stamp_of(ns: int) -> Time:
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def joint_state(i: int) -> JointState:
    """Deterministic values the Rust test recomputes (ros2/tests/cyclone_interop.rs)."""
    return JointState(
        header=Header(stamp=Time(sec=1000 + i, nanosec=250_000_000), frame_id=""),
        name=JOINT_NAMES,
        position=[0.1 * j + 0.001 * i for j in range(6)],
        velocity=[-0.5 * j for j in range(6)],
        effort=[],
    )


def image_data(i: int, width: int, height: int, encoding: str) -> bytes:
    """Pixels the Rust test recomputes: byte k of image i is ((k + i) * 7) mod 251."""
    n = width * height * (3 if encoding == "rgb8" else 4)
    pattern = bytes((k * 7) % 251 for k in range(251))
    reps = n // 251 + 2
    buf = (pattern * reps)[i % 251 : i % 251 + n]
    return buf


def make_image(i: int, width: int, height: int, encoding: str, frame: str) -> Image:
    bpp = 3 if encoding == "rgb8" else 4
    return Image(
        header=Header(stamp=Time(sec=2000 + i, nanosec=500), frame_id=frame),
        height=height,
        width=width,
        encoding=encoding,
        is_bigendian=0,
        step=width * bpp,
        data=image_data(i, width, height, encoding),
    )


def wait_for_readers(writers, n: int, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if all(len(w.get_matched_subscriptions()) >= n for w in writers):
            return True
        time.sleep(0.02)
    return False


def report(obj):
    text = json.dumps(obj)
    if ARGS.out:
        with open(ARGS.out, "w") as f:
            f.write(text)
    else:
        print(text, flush=True)


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def run_pub(dp: DomainParticipant, topic_name: str, cls, make, reliability: str, raw_template=None):
    topic = Topic(dp, dds_topic(topic_name), cls)
    writer = DataWriter(dp, topic, qos(reliability, ARGS.durability, ARGS.depth))
    t_match = time.monotonic()
    matched = ARGS.readers == 0 or wait_for_readers([writer], ARGS.readers, ARGS.wait_match)
    discovery_s = time.monotonic() - t_match
    if ARGS.readers > 0:
        time.sleep(ARGS.settle)
    period = 1.0 / ARGS.rate
    next_t = time.monotonic()
    write_s = []
    cdr_hex = []  # what Cyclone serialised, for byte-for-byte checks (small messages only)
    start = time.monotonic()
    ser = raw_template.serialize(use_version_2=writer._use_version_2) if raw_template else None
    for i in range(ARGS.count):
        if ser is not None:
            t0 = time.perf_counter()
            ddspy_write(writer._ref, patch_stamp(ser, now_ns()))
        else:
            sample = make(i)
            if cls is JointState:
                cdr_hex.append(sample.serialize(use_version_2=writer._use_version_2).hex())
            t0 = time.perf_counter()
            writer.write(sample, timestamp=now_ns())
        write_s.append(time.perf_counter() - t0)
        next_t += period
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    elapsed = time.monotonic() - start
    time.sleep(ARGS.linger)
    write_s.sort()
    report({
        "mode": ARGS.mode, "topic": topic_name, "sent": ARGS.count, "matched": matched,
        "discovery_s": discovery_s, "rate_hz": ARGS.count / elapsed if elapsed > 0 else None,
        "write_ms_p50": 1e3 * write_s[len(write_s) // 2] if write_s else None,
        "write_ms_max": 1e3 * write_s[-1] if write_s else None,
        "cdr_hex": cdr_hex,
    })


def describe(cls, s) -> dict:
    si = s.sample_info
    out = {"source_timestamp_ns": si.source_timestamp, "received_ns": now_ns()}
    if cls is JointState:
        out.update(stamp=[s.header.stamp.sec, s.header.stamp.nanosec], frame_id=s.header.frame_id,
                   name=list(s.name), position=list(s.position), velocity=list(s.velocity),
                   effort=list(s.effort))
    elif cls is Image:
        out.update(stamp=[s.header.stamp.sec, s.header.stamp.nanosec], frame_id=s.header.frame_id,
                   height=s.height, width=s.width, encoding=s.encoding, is_bigendian=s.is_bigendian,
                   step=s.step, data_len=len(s.data), data_head=list(bytes(s.data[:16])))
    elif cls is TaskEvent:
        out.update(task=s.task, state=s.state, kind=s.kind, reason_code=s.reason_code, text=s.text)
    else:
        out["transforms"] = [
            {"stamp": [t.header.stamp.sec, t.header.stamp.nanosec], "frame_id": t.header.frame_id,
             "child_frame_id": t.child_frame_id,
             "translation": [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
             "rotation": [t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                          t.transform.rotation.w]}
            for t in s.transforms
        ]
    return out


def run_sub(dp: DomainParticipant):
    cls = TYPES[ARGS.type]
    topic = Topic(dp, dds_topic(ARGS.topic), cls)
    reader = DataReader(dp, topic, qos(ARGS.reliability or "best-effort", ARGS.durability, ARGS.depth))
    received = []
    end = time.monotonic() + ARGS.timeout
    mask = SampleState.Any | ViewState.Any | InstanceState.Any
    while ARGS.raw and time.monotonic() < end and len(received) < ARGS.count:
        ret = ddspy_take(reader._ref, mask, 64)
        for data, info in [] if isinstance(ret, int) else ret:
            if info.valid_data:
                received.append({"source_timestamp_ns": info.source_timestamp, "received_ns": now_ns(),
                                 "cdr_len": len(data)})
        time.sleep(0.001)
    while not ARGS.raw and time.monotonic() < end and len(received) < ARGS.count:
        for s in reader.take(N=64):
            if not hasattr(s, "sample_info") or not s.sample_info.valid_data:
                continue  # dispose/unregister notices carry no fields
            received.append(describe(cls, s))
        time.sleep(0.002)
    report({"mode": "sub", "topic": ARGS.topic, "received": received})


def patch_stamp(template: bytes, ns: int) -> bytes:
    # header.stamp is the first field: sec int32 at payload offset 0, nanosec uint32 at 4,
    # after the 4-byte encapsulation header.
    return template[:4] + struct.pack("<iI", ns // 1_000_000_000, ns % 1_000_000_000) + template[12:]


def run_bench_pub(dp: DomainParticipant):
    w, h = ARGS.width, ARGS.height
    color = Image(Header(Time(0, 0), "camera_color_optical_frame"), h, w, "rgb8", 0, 3 * w,
                  image_data(0, w, h, "rgb8"))
    depth = Image(Header(Time(0, 0), "camera_color_optical_frame"), h, w, "32FC1", 0, 4 * w,
                  image_data(0, w, h, "32FC1"))
    js = joint_state(0)
    rel = ARGS.reliability or "best-effort"
    writers = {}
    for name, cls, r, sample in [
        ("/camera/color/image_raw", Image, rel, color),
        ("/camera/depth/image_raw", Image, rel, depth),
        ("/joint_states", JointState, "reliable", js),
    ]:
        wr = DataWriter(dp, Topic(dp, dds_topic(name), cls), qos(r, "volatile", ARGS.depth))
        writers[name] = (wr, sample.serialize(use_version_2=wr._use_version_2))
    matched = wait_for_readers([v[0] for v in writers.values()], ARGS.readers, ARGS.wait_match)
    time.sleep(ARGS.settle)
    sent = {k: 0 for k in writers}
    write_s = {k: [] for k in writers}
    start = time.monotonic()
    cpu0 = cpu_s()
    img_period, js_period = 1.0 / ARGS.rate, 1.0 / ARGS.js_rate
    next_img, next_js = start, start
    while True:
        t = time.monotonic()
        if t - start >= ARGS.duration:
            break
        due = []
        if t >= next_js:
            due.append("/joint_states")
            next_js += js_period
        if t >= next_img:
            due += ["/camera/color/image_raw", "/camera/depth/image_raw"]
            next_img += img_period
        for name in due:
            wr, template = writers[name]
            t0 = time.perf_counter()
            ret = ddspy_write(wr._ref, patch_stamp(template, now_ns()))
            write_s[name].append(time.perf_counter() - t0)
            if ret >= 0:
                sent[name] += 1
        time.sleep(max(0.0, min(next_img, next_js) - time.monotonic()))
    elapsed = time.monotonic() - start
    cpu = cpu_s() - cpu0
    time.sleep(ARGS.linger)
    summary = {}
    for k, v in write_s.items():
        v.sort()
        summary[k] = {"sent": sent[k], "write_ms_p50": 1e3 * v[len(v) // 2] if v else None,
                      "write_ms_max": 1e3 * v[-1] if v else None}
    report({"mode": "bench-pub", "matched": matched, "elapsed_s": elapsed,
            "cpu_core_fraction": cpu / elapsed if elapsed > 0 else None, "topics": summary})


def run_bench_sub(dp: DomainParticipant):
    rel = ARGS.reliability or "best-effort"
    readers = {}
    for name, cls, r in [
        ("/camera/color/image_raw", Image, rel),
        ("/camera/depth/image_raw", Image, rel),
        ("/joint_states", JointState, "reliable"),
    ]:
        readers[name] = DataReader(dp, Topic(dp, dds_topic(name), cls), qos(r, "volatile", ARGS.depth))
    lat = {k: [] for k in readers}
    mask = SampleState.Any | ViewState.Any | InstanceState.Any
    end = time.monotonic() + ARGS.duration
    cpu0, t0 = cpu_s(), time.monotonic()
    while time.monotonic() < end:
        for name, rd in readers.items():
            ret = ddspy_take(rd._ref, mask, 64)
            if isinstance(ret, int):
                continue
            for data, info in ret:
                if info.valid_data:
                    lat[name].append((now_ns() - info.source_timestamp) / 1e6)
        time.sleep(0.001)
    elapsed = time.monotonic() - t0
    cpu = cpu_s() - cpu0
    out = {}
    for k, v in lat.items():
        v.sort()
        out[k] = {"received": len(v), "latency_ms_p50": v[len(v) // 2] if v else None,
                  "latency_ms_p99": v[min(len(v) - 1, int(0.99 * len(v)))] if v else None}
    report({"mode": "bench-sub", "elapsed_s": elapsed,
            "cpu_core_fraction": cpu / elapsed if elapsed > 0 else None, "topics": out})


def run_serve_trigger(dp: DomainParticipant):
    name = ARGS.topic or "/trigger"
    rel = qos("reliable", "volatile", 10)
    reader = DataReader(dp, Topic(dp, "rq" + name + "Request", TriggerRequest), rel)
    writer = DataWriter(dp, Topic(dp, "rr" + name + "Reply", TriggerResponse), rel)
    mask = SampleState.Any | ViewState.Any | InstanceState.Any
    served = []
    end = time.monotonic() + ARGS.timeout
    while time.monotonic() < end and len(served) < ARGS.count:
        ret = ddspy_take(reader._ref, mask, 16)
        for data, info in [] if isinstance(ret, int) else ret:
            if not info.valid_data or len(data) < 20:
                continue
            client_id, seq = struct.unpack("<Qq", bytes(data[4:20]))
            writer.write(TriggerResponse(client_id=client_id, sequence=seq, success=True,
                                         message=f"captured {seq}"))
            served.append({"client_id": client_id, "sequence": seq, "request_hex": bytes(data).hex()})
        time.sleep(0.002)
    time.sleep(ARGS.linger)
    report({"mode": "serve-trigger", "served": served})


def run_sim_client(dp: DomainParticipant):
    """Joint states from the simulator node, then a capture this process asks for."""
    be = qos("best-effort", "volatile", 10)
    js_reader = DataReader(dp, Topic(dp, "rt/joint_states", JointState), be)
    img_reader = DataReader(dp, Topic(dp, "rt/camera/color/image_raw", Image), be)
    trigger = DataWriter(dp, Topic(dp, "rt/camera/trigger", Empty), qos("reliable", "volatile", 10))
    end = time.monotonic() + ARGS.timeout
    joint_states = []
    while time.monotonic() < end and len(joint_states) < ARGS.count:
        for s in js_reader.take(N=64):
            if hasattr(s, "header") and s.sample_info.valid_data:
                joint_states.append({"stamp": [s.header.stamp.sec, s.header.stamp.nanosec],
                                     "name": list(s.name), "position": list(s.position)})
        time.sleep(0.005)
    matched = wait_for_readers([trigger], 1, max(0.0, end - time.monotonic()))
    time.sleep(ARGS.settle)
    triggered_ns = now_ns()
    trigger.write(Empty(structure_needs_at_least_one_member=0))
    images = []
    while time.monotonic() < end and not images:
        for s in img_reader.take(N=8):
            if hasattr(s, "header") and s.sample_info.valid_data:
                images.append(describe(Image, s))
        time.sleep(0.005)
    report({"mode": "sim-client", "joint_states": joint_states, "trigger_matched": matched,
            "triggered_ns": triggered_ns, "images": images})


def status_class(typename: str, field: str):
    kind = {"uint8": uint8, "int8": int8, "int32": int32}[field]
    pkg, _, name = typename.split("/")

    @dataclass
    class Status(IdlStruct, typename=f"{pkg}::msg::dds_::{name}_"):
        mode: kind

    return Status


def trajectory_dict(t) -> dict:
    return {"joint_names": list(t.joint_names), "stamp": [t.header.stamp.sec, t.header.stamp.nanosec],
            "points": [{"positions": list(p.positions), "velocities": list(p.velocities),
                        "time_from_start": [p.time_from_start.sec, p.time_from_start.nanosec]}
                       for p in t.points]}


def run_robot(dp: DomainParticipant):
    """A robot for rodlog's command path to drive (module docs, mode `robot`)."""
    start = time.monotonic()
    rel = qos("reliable", "volatile", 10)
    js_writer = DataWriter(dp, Topic(dp, "rt/joint_states", JointState), rel)
    readers = {name: DataReader(dp, Topic(dp, dds_topic(name), cls), rel) for name, cls in COMMAND_TOPICS}
    estop = DataWriter(dp, Topic(dp, "rt/estop", Empty), rel) if ARGS.estop_after else None
    status = None
    if ARGS.status_topic:
        cls = status_class(ARGS.status_type, ARGS.status_field)
        status = (DataWriter(dp, Topic(dp, dds_topic(ARGS.status_topic), cls), rel), cls)
    server = None
    if ARGS.action:
        a = ARGS.action
        server = {
            "goal_rq": DataReader(dp, Topic(dp, "rq" + a + "/_action/send_goalRequest", SendGoalRequest), rel),
            "goal_rr": DataWriter(dp, Topic(dp, "rr" + a + "/_action/send_goalReply", SendGoalResponse), rel),
            "result_rq": DataReader(dp, Topic(dp, "rq" + a + "/_action/get_resultRequest", GetResultRequest), rel),
            "result_rr": DataWriter(dp, Topic(dp, "rr" + a + "/_action/get_resultReply", GetResultResponse), rel),
            "cancel_rq": DataReader(dp, Topic(dp, "rq" + a + "/_action/cancel_goalRequest", CancelGoalRequest), rel),
            "cancel_rr": DataWriter(dp, Topic(dp, "rr" + a + "/_action/cancel_goalReply", CancelGoalResponse), rel),
        }
    builtin = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    mask = SampleState.Any | ViewState.Any | InstanceState.Any
    commands, goals, cancels, writer_topics = [], [], 0, set()
    active = {}   # goal uuid -> end time
    waiting = []  # (client_id, sequence, uuid) get_result requests
    results = {}  # uuid -> status once ended
    js_on, estop_sent = True, False
    next_js, js_period = start, 1.0 / ARGS.js_rate
    next_status = start
    js_sent = 0
    while time.monotonic() - start < ARGS.duration:
        now = time.monotonic()
        if js_on and now >= next_js:
            js_writer.write(JointState(header=Header(stamp=stamp_of(now_ns()), frame_id=""),
                                       name=RODLOG_ARM_JOINTS, position=[0.0, 0.3, 1.5, 0.0, -1.2, 0.0],
                                       velocity=[0.0] * 6, effort=[]))
            js_sent += 1
            next_js += js_period
        if status and now >= next_status:
            status[0].write(status[1](mode=ARGS.status_value))
            next_status += 0.05
        for name, rd in readers.items():
            ret = ddspy_take(rd._ref, mask, 16)
            for data, info in [] if isinstance(ret, int) else ret:
                if info.valid_data:
                    commands.append({"topic": name, "cdr_hex": bytes(data).hex(),
                                     "t": now - start})
        n = len(commands)
        if ARGS.stop_js_after and n >= ARGS.stop_js_after:
            js_on = False
        if estop and not estop_sent and n >= ARGS.estop_after:
            estop.write(Empty(structure_needs_at_least_one_member=0))
            estop_sent = True
        if server:
            for r in server["goal_rq"].take(N=8):
                if not hasattr(r, "goal_id"):
                    continue
                uuid = bytes(r.goal_id.uuid).hex()
                t = r.goal.trajectory
                goals.append({"goal_id": uuid, "trajectory": trajectory_dict(t), "t": now - start})
                end = max([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in t.points] + [0.0])
                active[uuid] = now + min(end, 1.0)
                server["goal_rr"].write(SendGoalResponse(client_id=r.client_id, sequence=r.sequence,
                                                         accepted=True, stamp=stamp_of(now_ns())))
            for r in server["result_rq"].take(N=8):
                if hasattr(r, "goal_id"):
                    waiting.append((r.client_id, r.sequence, bytes(r.goal_id.uuid).hex()))
            for r in server["cancel_rq"].take(N=8):
                if not hasattr(r, "goal_info"):
                    continue
                cancels += 1
                canceling = []
                for uuid in list(active):
                    results[uuid] = 5  # CANCELED
                    del active[uuid]
                    canceling.append(GoalInfo(goal_id=UUID(uuid=list(bytes.fromhex(uuid))), stamp=Time(0, 0)))
                server["cancel_rr"].write(CancelGoalResponse(client_id=r.client_id, sequence=r.sequence,
                                                             return_code=0, goals_canceling=canceling))
            for uuid, end in list(active.items()):
                if now >= end:
                    results[uuid] = 4  # SUCCEEDED
                    del active[uuid]
            for w in list(waiting):
                if w[2] in results:
                    server["result_rr"].write(GetResultResponse(
                        client_id=w[0], sequence=w[1], status=results[w[2]],
                        result=FJTResult(error_code=0, error_string="")))
                    waiting.remove(w)
        for s in builtin.take(N=64):
            name = getattr(s, "topic_name", None)
            if name and getattr(s, "participant_key", None) != dp.guid:
                writer_topics.add(name)
        time.sleep(0.002)
    time.sleep(ARGS.linger)
    report({"mode": "robot", "commands": commands, "goals": goals, "cancels": cancels,
            "results": {k: v for k, v in results.items()}, "writer_topics": sorted(writer_topics),
            "joint_states_sent": js_sent, "estop_sent": estop_sent})


def main():
    domain = ARGS.domain if ARGS.domain is not None else int(os.environ.get("ROS_DOMAIN_ID", "0"))
    dp = DomainParticipant(domain)
    if ARGS.mode == "pub-joint-states":
        run_pub(dp, ARGS.topic or "/joint_states", JointState, joint_state, ARGS.reliability or "reliable")
    elif ARGS.mode == "pub-image":
        topic = ARGS.topic or "/camera/color/image_raw"
        w, h, enc = ARGS.width, ARGS.height, ARGS.encoding
        template = make_image(0, w, h, enc, "camera_color_optical_frame")

        def make(i):
            template.header.stamp = Time(sec=2000 + i, nanosec=500)
            template.data = image_data(i, w, h, enc)
            return template

        run_pub(dp, topic, Image, make, ARGS.reliability or "best-effort",
                raw_template=template if ARGS.raw else None)
    elif ARGS.mode == "sub":
        run_sub(dp)
    elif ARGS.mode == "bench-pub":
        run_bench_pub(dp)
    elif ARGS.mode == "serve-trigger":
        run_serve_trigger(dp)
    elif ARGS.mode == "sim-client":
        run_sim_client(dp)
    elif ARGS.mode == "robot":
        run_robot(dp)
    else:
        run_bench_sub(dp)


if __name__ == "__main__":
    sys.exit(main())
