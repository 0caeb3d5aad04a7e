"""Robot logs (MCAP) through Foxglove's Python packages: `mcap`, `mcap-ros1-support` and
`mcap-ros2-support`.

`decode FILE` prints what Foxglove's ROS 1 and ROS 2 decoders read from FILE, in file
order: one JSON line per message, {"topic", "schema", "log_time", "sequence", "message"},
byte arrays as lists of integers, ROS 1 time and duration as {"secs", "nsecs"},
non-finite floats as strings.

`convert-ros1 ROS2_LOG OUT` writes OUT with the package's writer (LZ4 chunks), the way a bag converted from
ROS 1 looks, then decodes it as above. OUT holds the robot drive of a ROS 2 log (read with `mcap-ros2-support`) as ROS 1
messages: /odom nav_msgs/Odometry, /goal geometry_msgs/PoseStamped, /tf_static
tf/tfMessage, /tf tf2_msgs/TFMessage, /map nav_msgs/OccupancyGrid (the ROS 2 log's first
GridMap layer as occupancy), and /everything, one message type that uses every ROS 1
field kind.

usage: foxglove_mcap.py decode FILE.mcap | foxglove_mcap.py convert-ros1 ROS2_LOG.mcap OUT.mcap
"""

import json
import math
import sys

from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap_ros1._vendor.genpy import dynamic
from mcap_ros1._vendor.genpy.rostime import Duration, Time
from mcap_ros1.decoder import DecoderFactory as Ros1Decoders
from mcap_ros1.writer import Writer
from mcap_ros2.decoder import DecoderFactory as Ros2Decoders

SEPARATOR = "\n" + "=" * 80 + "\n"

DEFINITIONS = {
    "std_msgs/Header": "uint32 seq\ntime stamp\nstring frame_id\n",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    "geometry_msgs/Pose": "Point position\nQuaternion orientation\n",
    "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance\n",
    "geometry_msgs/Twist": "Vector3 linear\nVector3 angular\n",
    "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance\n",
    "geometry_msgs/PoseStamped": "Header header\nPose pose\n",
    "geometry_msgs/Transform": "Vector3 translation\nQuaternion rotation\n",
    "geometry_msgs/TransformStamped": (
        "Header header\nstring child_frame_id # the frame id of the child frame\n"
        "Transform transform\n"
    ),
    "nav_msgs/Odometry": (
        "# This represents an estimate of a position and velocity in free space.\n"
        "Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n"
    ),
    "nav_msgs/MapMetaData": (
        "time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\n"
        "geometry_msgs/Pose origin\n"
    ),
    "nav_msgs/OccupancyGrid": "Header header\nMapMetaData info\nint8[] data\n",
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "tf/tfMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "imitate_test/Inner": "int16 a\nstring name\ngeometry_msgs/Point p\n",
    "imitate_test/Empty": "int32 ONLY_A_CONSTANT=7\n",
    "imitate_test/Everything": """# Every kind of field ROS 1 has.
uint8 MODE_A=1  # a comment after a constant
string GREETING=hello # this is part of the string
bool FLAG=True
byte SIGNED=-5
char UNSIGNED=200
Header header
bool b
byte by
char ch
int8 i8
uint8 u8
int16 i16
uint16 u16
int32 i32
uint32 u32
int64 i64
uint64 u64
float32 f32
float64 f64
string s
time t
duration d
uint8[] bytes
uint8[3] fixed_bytes
char[] chars
byte[] signed_bytes
int32[] ints
float32[4] floats
float64[] doubles
string[] strings
string[2] pair
bool[] flags
time[] times
duration[2] durations
Inner inner
Inner[] inners
Inner[2] inner_pair
Empty empty
Empty[] empties
""",
}


def dependencies(name, seen):
    """The message types `name` uses, depth first, each once (as `gendeps --cat`)."""
    package = name.split("/")[0]
    for line in DEFINITIONS[name].splitlines():
        line = line.split("#")[0].strip()
        if not line or "=" in line:
            continue
        base = line.split()[0].split("[")[0]
        if base == "Header":
            base = "std_msgs/Header"
        elif "/" not in base:
            base = f"{package}/{base}"
        if base in DEFINITIONS and base not in seen:
            seen.append(base)
            dependencies(base, seen)
    return seen


def full_text(name):
    text = DEFINITIONS[name]
    for dependency in dependencies(name, []):
        text += SEPARATOR + f"MSG: {dependency}\n" + DEFINITIONS[dependency]
    return text



def time_of(stamp):
    return Time(stamp.sec, stamp.nanosec)


def header(ros2_header, seq, types):
    return types["std_msgs/Header"](seq, time_of(ros2_header.stamp), ros2_header.frame_id)


def transforms(ros2_message, seq, cls):
    types = cls._imitate_types
    items = []
    for t in ros2_message.transforms:
        tr, rot = t.transform.translation, t.transform.rotation
        items.append(
            types["geometry_msgs/TransformStamped"](
                header(t.header, seq, types),
                t.child_frame_id,
                types["geometry_msgs/Transform"](
                    types["geometry_msgs/Vector3"](tr.x, tr.y, tr.z),
                    types["geometry_msgs/Quaternion"](rot.x, rot.y, rot.z, rot.w),
                ),
            )
        )
    return cls(items)


def classes(name):
    generated = dynamic.generate_dynamic(name, full_text(name))
    cls = generated[name]
    cls._imitate_types = generated
    return cls


def convert(ros2_log, out):
    odometry = classes("nav_msgs/Odometry")
    pose_stamped = classes("geometry_msgs/PoseStamped")
    tf_message = classes("tf/tfMessage")
    tf2_message = classes("tf2_msgs/TFMessage")
    occupancy = classes("nav_msgs/OccupancyGrid")
    everything = classes("imitate_test/Everything")
    # LZ4 chunks: the ROS 2 bags and the mcap crate's ROS 1 files cover zstd and none.
    writer = Writer(open(out, "wb"), chunk_size=64 * 1024, compression=CompressionType.LZ4)
    sequence = {}
    with open(ros2_log, "rb") as f:
        reader = make_reader(f, decoder_factories=[Ros2Decoders()])
        for schema, channel, message, m in reader.iter_decoded_messages():
            seq = sequence.setdefault(channel.topic, 0)
            sequence[channel.topic] += 1
            if schema.name == "nav_msgs/msg/Odometry":
                t = odometry._imitate_types
                p, q = m.pose.pose.position, m.pose.pose.orientation
                v, w = m.twist.twist.linear, m.twist.twist.angular
                ros1 = odometry(
                    header(m.header, seq, t),
                    m.child_frame_id,
                    t["geometry_msgs/PoseWithCovariance"](
                        t["geometry_msgs/Pose"](
                            t["geometry_msgs/Point"](p.x, p.y, p.z),
                            t["geometry_msgs/Quaternion"](q.x, q.y, q.z, q.w),
                        ),
                        [float(i) for i in range(36)],
                    ),
                    t["geometry_msgs/TwistWithCovariance"](
                        t["geometry_msgs/Twist"](
                            t["geometry_msgs/Vector3"](v.x, v.y, v.z),
                            t["geometry_msgs/Vector3"](w.x, w.y, w.z),
                        ),
                        [0.0] * 36,
                    ),
                )
                # Every 50th pose also goes out on /tf, as a driver publishes it.
                if seq % 50 == 0:
                    tf = tf2_message._imitate_types
                    writer.write_message(
                        "/tf",
                        tf2_message(
                            [
                                tf["geometry_msgs/TransformStamped"](
                                    header(m.header, seq, tf),
                                    "base_link",
                                    tf["geometry_msgs/Transform"](
                                        tf["geometry_msgs/Vector3"](p.x, p.y, p.z),
                                        tf["geometry_msgs/Quaternion"](q.x, q.y, q.z, q.w),
                                    ),
                                )
                            ]
                        ),
                        log_time=message.log_time,
                        sequence=seq // 50,
                    )
            elif schema.name == "geometry_msgs/msg/PoseStamped":
                t = pose_stamped._imitate_types
                p, q = m.pose.position, m.pose.orientation
                ros1 = pose_stamped(
                    header(m.header, seq, t),
                    t["geometry_msgs/Pose"](
                        t["geometry_msgs/Point"](p.x, p.y, p.z),
                        t["geometry_msgs/Quaternion"](q.x, q.y, q.z, q.w),
                    ),
                )
            elif schema.name == "tf2_msgs/msg/TFMessage":
                ros1 = transforms(m, seq, tf_message)
            elif schema.name == "grid_map_msgs/msg/GridMap":
                ros1 = occupancy_of(m, seq, occupancy)
            else:
                continue
            writer.write_message(
                channel.topic, ros1, log_time=message.log_time, sequence=message.sequence
            )
    for k in range(3):
        writer.write_message(
            "/everything", sample(everything, k), log_time=1_700_000_000_000_000_000 + k
        )
    writer.finish()


def occupancy_of(grid_map, seq, cls):
    """The first layer of a GridMap as occupancy (0..100, -1 for NaN), rows from the
    bottom (OccupancyGrid) where GridMap's storage runs from the top-left corner."""
    t = cls._imitate_types
    info = grid_map.info
    columns = round(info.length_x / info.resolution)
    rows = round(info.length_y / info.resolution)
    values = grid_map.data[0].data
    low, high = min(values), max(values)
    data = []
    for y in range(rows):
        for x in range(columns):
            # GridMap: index (i, j) with i along -x, j along -y, column-major.
            value = values[(rows - 1 - y) * columns + (columns - 1 - x)]
            data.append(-1 if math.isnan(value) else round(100 * (value - low) / (high - low)))
    centre = info.pose.position
    origin = t["geometry_msgs/Pose"](
        t["geometry_msgs/Point"](
            centre.x - info.length_x / 2, centre.y - info.length_y / 2, 0.0
        ),
        t["geometry_msgs/Quaternion"](0.0, 0.0, 0.0, 1.0),
    )
    return cls(
        header(grid_map.header, seq, t),
        t["nav_msgs/MapMetaData"](
            time_of(grid_map.header.stamp), info.resolution, columns, rows, origin
        ),
        data,
    )


def sample(cls, k):
    t = cls._imitate_types
    inner = t["imitate_test/Inner"]
    point = t["geometry_msgs/Point"]
    empty = t["imitate_test/Empty"]
    return cls(
        header=t["std_msgs/Header"](k, Time(1_700_000_000 + k, 250_000_000), f"frame_{k}"),
        b=k % 2 == 1,
        by=-128 + k,
        ch=255 - k,
        i8=-7,
        u8=200,
        i16=-30000,
        u16=65535,
        i32=-(2**31),
        u32=2**32 - 1,
        i64=-(2**63),
        u64=2**64 - 1,
        f32=0.1 * (k + 1),
        f64=[math.pi, float("nan"), float("inf")][k],
        s=["", "héllo wörld ✓", "tab\tand\nnewline"][k],
        t=Time(k, 999_999_999),
        d=Duration(-k - 1, 500),
        bytes=bytes(range(k * 3)),
        fixed_bytes=bytes([k, 128, 255]),
        chars=b"abc"[: k + 1],
        signed_bytes=[-1, 0, 127][: k + 1],
        ints=list(range(-k, k)),
        floats=[1.5, -0.0, 3.25e-8, float("-inf")],
        doubles=[1e300 * k, -2.5][: k + 1],
        strings=["a", "", "ünï"][:k],
        pair=["left", "right"],
        flags=[True, False, True][: k + 1],
        times=[Time(i, i) for i in range(k)],
        durations=[Duration(-1, 0), Duration(2, 3)],
        inner=inner(k, "inner", point(1.0, 2.0, 3.0)),
        inners=[inner(i, f"n{i}", point(i, -i, 0.5)) for i in range(k)],
        inner_pair=[inner(-1, "x", point(0, 0, 0)), inner(1, "y", point(1, 1, 1))],
        empty=empty(),
        empties=[empty() for _ in range(k)],
    )


def plain(value):
    if isinstance(value, (Time, Duration)):
        return {"secs": value.secs, "nsecs": value.nsecs}
    if hasattr(value, "__slots__"):
        return {k: plain(getattr(value, k)) for k in value.__slots__}
    if isinstance(value, (list, tuple)):
        return [plain(x) for x in value]
    if isinstance(value, bytes):
        return list(value)
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def decode(path):
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[Ros1Decoders(), Ros2Decoders()])
        for schema, channel, message, decoded in reader.iter_decoded_messages(
            log_time_order=False
        ):
            print(
                json.dumps(
                    {
                        "topic": channel.topic,
                        "schema": schema.name,
                        "log_time": message.log_time,
                        "sequence": message.sequence,
                        "message": plain(decoded),
                    }
                )
            )


if __name__ == "__main__":
    if sys.argv[1] == "convert-ros1":
        convert(sys.argv[2], sys.argv[3])
    decode(sys.argv[-1])
