"""Reading and writing bags: round trips, numpy fast path == rosbags' deserialisers, ROS 1 == rosbag2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from imu_noise_id.bag.reader import (
    read_bag,
    read_imu,
    read_odometry,
    read_static,
)
from imu_noise_id.bag.topics import IMU_TYPE, ODOM_TYPE, TEMPERATURE_TYPE, list_topics
from imu_noise_id.bag.writer import encode_cdr, write_bag
from imu_noise_id.core.axes import ImuSeries, OdometrySeries, ScalarSeries
from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.simulation.static import simulate_static_imu

HUSKY = "husky_robot_localization"


def simulated_imu(duration: float = 20.0, rate: float = 100.0, t0: float = 1.7e9 + 0.123, seed: int = 1) -> ImuSeries:
    model = parse_imu_model("gyro: WN(1e-3)+RW(1e-5); accel: WN(2e-3)+RW(4e-4)")
    return simulate_static_imu(model, rate, duration, seed=seed, t0=t0)


def simulated_odometry(n: int = 200, t0: float = 1.7e9) -> OdometrySeries:
    rng = np.random.default_rng(5)
    quat = rng.normal(size=(n, 4))
    return OdometrySeries(
        t=t0 + 0.1 * np.arange(n),
        position=rng.normal(size=(n, 3)),
        orientation_xyzw=quat / np.linalg.norm(quat, axis=1, keepdims=True),
        linear_velocity=rng.normal(size=(n, 3)),
        angular_velocity=rng.normal(size=(n, 3)),
        pose_covariance=rng.normal(size=(n, 6, 6)),
        twist_covariance=rng.normal(size=(n, 6, 6)),
        frame_id="odom",
        child_frame_id="base_footprint",
    )


def assert_same_times(actual: np.ndarray, expected: np.ndarray) -> None:
    # Stamps are stored as integer nanoseconds: equal to 1 ns plus the float64 spacing at 1.7e9 s (2.4e-7 s).
    np.testing.assert_allclose(actual, expected, rtol=0, atol=3e-7)


@pytest.fixture(scope="module")
def imu() -> ImuSeries:
    return simulated_imu()


@pytest.fixture(scope="module", params=["mcap", "sqlite3"])
def full_bag(request, tmp_path_factory, imu) -> tuple[Path, OdometrySeries, ScalarSeries]:
    odom = simulated_odometry()
    temp = ScalarSeries(t=1.7e9 + np.arange(20.0), value=25.0 + 0.01 * np.arange(20.0))
    path = tmp_path_factory.mktemp("bags") / request.param
    write_bag(path, imu, odom, temp, storage=request.param)
    return path, odom, temp


def test_round_trip_equals_the_written_arrays(full_bag, imu):
    path, odom, temp = full_bag
    assert list_topics(path) == {
        "/imu/data": (IMU_TYPE, len(imu)),
        "/odom": (ODOM_TYPE, len(odom)),
        "/imu/temperature": (TEMPERATURE_TYPE, len(temp.t)),
    }
    calls = []
    bag = read_bag(path, progress=lambda done, total: calls.append((done, total)))
    assert bag.notes == [] and bag.imu.notes == []
    assert calls[-1] == (len(imu) + len(odom) + 20, len(imu) + len(odom) + 20)
    assert_same_times(bag.imu.t, imu.t)
    np.testing.assert_array_equal(bag.imu.gyro, imu.gyro)
    np.testing.assert_array_equal(bag.imu.accel, imu.accel)
    assert (bag.imu.frame_id, bag.imu.topic) == ("imu_link", "/imu/data")
    assert_same_times(bag.odom.t, odom.t)
    for name in ("position", "orientation_xyzw", "linear_velocity", "angular_velocity"):
        np.testing.assert_array_equal(getattr(bag.odom, name), getattr(odom, name))
    np.testing.assert_array_equal(bag.odom.pose_covariance, odom.pose_covariance)
    np.testing.assert_array_equal(bag.odom.twist_covariance, odom.twist_covariance)
    assert (bag.odom.frame_id, bag.odom.child_frame_id) == ("odom", "base_footprint")
    np.testing.assert_array_equal(bag.temperature.value, temp.value)
    # Every message went through the numpy path.
    assert all(fallback == 0 for _, fallback in bag.decode_stats.values())
    # The single-topic readers give the same arrays.
    np.testing.assert_array_equal(read_imu(path).gyro, imu.gyro)
    np.testing.assert_array_equal(read_odometry(path).position, odom.position)
    np.testing.assert_array_equal(read_static(path).temperature.value, temp.value)


def test_fast_path_equals_full_deserialisation(full_bag):
    path, _, _ = full_bag
    fast, slow = read_bag(path), read_bag(path, fast=False)
    assert all(f == 0 for _, f in fast.decode_stats.values()) and all(n == 0 for n, _ in slow.decode_stats.values())
    for name in ("t", "gyro", "accel"):
        np.testing.assert_array_equal(getattr(fast.imu, name), getattr(slow.imu, name))
    assert fast.imu.orientation_xyzw is None and slow.imu.orientation_xyzw is None  # simulated: not provided
    for name in ("t", "position", "orientation_xyzw", "pose_covariance", "twist_covariance", "angular_velocity"):
        np.testing.assert_array_equal(getattr(fast.odom, name), getattr(slow.odom, name))
    np.testing.assert_array_equal(fast.temperature.value, slow.temperature.value)


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_imu_orientation_round_trip_fast_equals_full(tmp_path, storage, monkeypatch):
    """The Imu orientation comes back as written, NaN where a message says "not provided" (REP-145:
    orientation_covariance[0] = -1), identically on the numpy path and with full deserialisation; batches before
    the first provided orientation (no array allocated yet) read as not provided."""
    import imu_noise_id.bag.stream as stream

    monkeypatch.setattr(stream, "BATCH", 50)
    imu = simulated_imu(duration=5.0)
    rng = np.random.default_rng(8)
    q = rng.normal(size=(len(imu), 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[::7] = np.nan  # written with orientation_covariance[0] = -1
    q[:120] = np.nan  # the first batches provide none
    imu.orientation_xyzw = q
    write_bag(tmp_path / storage, imu, storage=storage)
    fast, slow = read_bag(tmp_path / storage), read_bag(tmp_path / storage, fast=False)
    assert fast.decode_stats["/imu/data"] == (len(imu), 0) and slow.decode_stats["/imu/data"] == (0, len(imu))
    np.testing.assert_array_equal(fast.imu.orientation_xyzw, q)
    np.testing.assert_array_equal(slow.imu.orientation_xyzw, q)
    np.testing.assert_array_equal(read_imu(tmp_path / storage).orientation_xyzw, q)
    np.testing.assert_array_equal(fast.imu.gyro, imu.gyro)


def test_independent_deserialisation_matches(full_bag):
    """Values read by the numpy path equal rosbags' AnyReader + deserialize_cdr, message by message."""
    from rosbags.highlevel import AnyReader

    path, _, _ = full_bag
    bag = read_bag(path)
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic == "/imu/data"]
        msgs = [reader.deserialize(raw, IMU_TYPE) for _, _, raw in reader.messages(connections=conns)]
    t = np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in msgs])
    gyro = np.array([[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z] for m in msgs])
    accel = np.array([[m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z] for m in msgs])
    np.testing.assert_array_equal(bag.imu.t, t)
    np.testing.assert_array_equal(bag.imu.gyro, gyro)
    np.testing.assert_array_equal(bag.imu.accel, accel)
    assert msgs[0].orientation_covariance[0] == -1.0  # REP-145: orientation not provided
    assert bag.imu_covariance["orientation"][0, 0] == -1.0
    np.testing.assert_array_equal(bag.imu_covariance["angular_velocity"], np.zeros((3, 3)))


def test_mixed_frame_id_lengths_use_both_paths_and_stay_exact(tmp_path):
    """Messages with other frame_id lengths or byte order have other offsets but may share a total length.

    frame_ids of 4…11 characters all give 24 bytes up to the first double, in two byte orders: 16 layouts of one
    length. The decoder takes MAX_LAYOUTS_PER_LENGTH (8) of them with numpy and deserialises the rest.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    imu = simulated_imu(duration=2.0)
    frames = ["imu_link_frame"[:k] for k in range(4, 12)]
    with Writer(tmp_path / "mixed", version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/imu", IMU_TYPE, typestore=store)
        for i in range(len(imu)):
            values = {
                "header.stamp.sec": np.array([int(imu.t[i])]),
                "header.stamp.nanosec": np.array([round((imu.t[i] % 1) * 1e9)]),
                "angular_velocity.x": imu.gyro[i : i + 1, 0],
                "angular_velocity.z": imu.gyro[i : i + 1, 2],
                "linear_acceleration.z": imu.accel[i : i + 1, 2],
                "orientation.z": np.array([np.sin(0.01 * i)]),
                "orientation.w": np.array([np.cos(0.01 * i)]),
                "orientation_covariance": np.array([[-1.0 if i % 3 == 0 else 0.01, *[0.0] * 8]]),
            }
            buf, _ = encode_cdr(store.fielddefs, IMU_TYPE, values, {"header.frame_id": frames[i % 8]})
            data = buf[0].tobytes()
            if i % 16 >= 8:  # big-endian CDR (valid, other byte order)
                msg = store.deserialize_cdr(data, IMU_TYPE)
                data = bytes(store.serialize_cdr(msg, IMU_TYPE, little_endian=False))
            writer.write(conn, 1_000 + i, data)
    fast, slow = read_bag(tmp_path / "mixed"), read_bag(tmp_path / "mixed", fast=False)
    n_fast, n_fallback = fast.decode_stats["/imu"]
    assert n_fallback > 0 and n_fast > 0 and n_fast + n_fallback == len(imu)
    for name in ("t", "gyro", "accel", "orientation_xyzw"):
        np.testing.assert_array_equal(getattr(fast.imu, name), getattr(slow.imu, name))
    np.testing.assert_array_equal(fast.imu.gyro[:, [0, 2]], imu.gyro[:, [0, 2]])
    k = np.arange(len(imu))
    expected = np.column_stack([0 * k, 0 * k, np.sin(0.01 * k), np.cos(0.01 * k)])
    expected[k % 3 == 0] = np.nan  # orientation_covariance[0] = -1: not provided
    np.testing.assert_array_equal(fast.imu.orientation_xyzw, expected)
    assert fast.imu.frame_id == "imu_" and any("header.frame_id changes" in n for n in fast.notes)


def test_numpy_cdr_encoding_equals_serialize_cdr():
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    odom = simulated_odometry(n=3)
    ns = np.array([1_700_000_000_123_456_789, 5, 1_700_000_001_000_000_000])
    values = {"header.stamp.sec": ns // 10**9, "header.stamp.nanosec": ns % 10**9}
    for i, c in enumerate("xyz"):
        values[f"pose.pose.position.{c}"] = odom.position[:, i]
        values[f"twist.twist.angular.{c}"] = odom.angular_velocity[:, i]
    values["pose.covariance"] = odom.pose_covariance.reshape(3, 36)
    for frame, child in [("odom", "base_link"), ("", "x"), ("map_frame", "")]:
        buf, length = encode_cdr(
            store.fielddefs, ODOM_TYPE, values, {"header.frame_id": frame, "child_frame_id": child}
        )
        for i in range(3):
            msg = store.deserialize_cdr(buf[i].tobytes(), ODOM_TYPE)
            assert (msg.header.frame_id, msg.child_frame_id) == (frame, child)
            assert msg.pose.pose.position.y == odom.position[i, 1]
            assert bytes(store.serialize_cdr(msg, ODOM_TYPE)) == buf[i].tobytes()
            assert len(buf[i]) == length


def test_ros1_bag_equals_its_rosbag2_copy(shared_data):
    """The Husky ROS 1 bag and its rosbag2 (sqlite3) conversion give identical arrays, fast and slow."""
    ros1_path = shared_data / HUSKY / "test1.bag"
    ros2_path = shared_data / HUSKY / "husky_test1_ros2"
    if not ros1_path.exists() or not ros2_path.exists():
        pytest.skip("Husky bags absent")
    ros1, ros2 = read_bag(ros1_path), read_bag(ros2_path)
    ros1_slow = read_bag(ros1_path, fast=False)
    assert len(ros1.imu) == 11865 and len(ros1.odom) == 3952
    assert ros1.decode_stats["/imu/data"] == (11865, 0)
    for other in (ros2, ros1_slow):
        for name in ("t", "gyro", "accel", "orientation_xyzw"):
            np.testing.assert_array_equal(getattr(ros1.imu, name), getattr(other.imu, name))
        for name in ("t", "position", "orientation_xyzw", "linear_velocity", "angular_velocity", "twist_covariance"):
            np.testing.assert_array_equal(getattr(ros1.odom, name), getattr(other.odom, name))
    assert (ros1.odom.frame_id, ros1.odom.child_frame_id, ros1.imu.frame_id) == ("odom", "base_link", "imu_link")
    # The Husky's UM6 provides its orientation in every message: unit quaternions
    assert ros1.imu.orientation_xyzw is not None and np.isfinite(ros1.imu.orientation_xyzw).all()
    np.testing.assert_allclose(np.linalg.norm(ros1.imu.orientation_xyzw, axis=1), 1.0, atol=1e-3)
    # Declared covariances of the Husky IMU (README): angular velocity 4e-4 (rad/s)², acceleration 9.604e-3 (m/s²)².
    np.testing.assert_allclose(np.diag(ros1.imu_covariance["angular_velocity"]), [4e-4] * 3)
    np.testing.assert_allclose(np.diag(ros2.imu_covariance["linear_acceleration"]), [9.604e-3] * 3)
    # Independent check against the npz made from the same messages (times relative to the first IMU stamp).
    npz = np.load(shared_data / HUSKY / "husky_test1.npz")
    np.testing.assert_array_equal(ros1.imu.gyro, npz["imu_gyro"])
    np.testing.assert_array_equal(ros1.odom.linear_velocity, npz["odom_twist_linear"])
    np.testing.assert_array_equal(ros1.imu.orientation_xyzw, npz["imu_quat_xyzw"])
    np.testing.assert_allclose(ros1.imu.t - ros1.imu.t[0], npz["imu_t"], rtol=0, atol=1e-6)


def test_fast_mcap_iteration_equals_rosbags(tmp_path, full_bag):
    """The chunk walker yields the same (connection, log time, bytes) sequence as AnyReader.messages."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
    from rosbags.typesys import Stores, get_typestore

    from imu_noise_id.bag.mcapfast import fast_mcap_messages

    path, _, _ = full_bag
    store = get_typestore(Stores.ROS2_JAZZY)
    compressed = tmp_path / "zstd"
    writer = Writer(compressed, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)  # zstd chunks
    with writer:
        conn = writer.add_connection("/imu", IMU_TYPE, typestore=store)
        buf, _ = encode_cdr(store.fielddefs, IMU_TYPE, {"angular_velocity.x": np.arange(3000.0) * 1e-3}, {})
        for i in range(3000):
            writer.write(conn, 10_000 + 7 * i, buf[i].tobytes())
    for bag in (path, compressed):
        with AnyReader([bag]) as reader:
            fast = fast_mcap_messages(reader, reader.connections)
            if bag.name == "sqlite3":
                assert fast is None  # not an mcap bag: rosbags' iteration is used
                continue
            got = [(c.topic, t, d) for c, t, d in fast]
            ref = [(c.topic, t, d) for c, t, d in reader.messages(connections=reader.connections)]
            assert got == ref and len(got) > 1000
    assert np.array_equal(read_imu(compressed).gyro[:, 0], np.arange(3000.0) * 1e-3)


def test_types_without_fixed_layout_are_fully_deserialised():
    """A type with sequences (sensor_msgs/JointState) cannot take the numpy path: every message is deserialised."""
    from rosbags.typesys import Stores, get_typestore

    from imu_noise_id.bag.fastdecode import FlatDecoder, NotFlatError, flatten

    store = get_typestore(Stores.ROS2_JAZZY)
    joint_state = "sensor_msgs/msg/JointState"
    with pytest.raises(NotFlatError, match="name has no fixed layout"):
        flatten(store.fielddefs, joint_state)
    Time, Header = store.types["builtin_interfaces/msg/Time"], store.types["std_msgs/msg/Header"]
    empty = np.array([], dtype=float)
    msgs = [
        store.types[joint_state](
            header=Header(stamp=Time(sec=10 + i, nanosec=5), frame_id="j"),
            name=["a"],
            position=np.array([0.5 * i]),
            velocity=empty,
            effort=empty,
        )
        for i in range(4)
    ]
    raws = [bytes(store.serialize_cdr(m, joint_state)) for m in msgs]
    decoder = FlatDecoder(
        store.fielddefs, joint_state, {"sec": ("header.stamp.sec",)},
        strings=("header.frame_id",), ros1=False, deserialize=store.deserialize_cdr,
    )  # fmt: skip
    sec = np.empty(4, dtype=np.int64)
    decoder.decode(raws, {"sec": sec})
    assert not decoder.fast and (decoder.stats.fast, decoder.stats.fallback) == (0, 4)
    np.testing.assert_array_equal(sec, [10, 11, 12, 13])
    assert decoder.strings == {"header.frame_id": "j"}
