"""ctypes mirror of the polarnav wire payloads (msgs/src/payloads.rs).

Field order, types and explicit padding follow the Rust `#[repr(C)]` structs
exactly; `type_name()` returns the versioned iceoryx2 type name, so iceoryx2
accepts these types when opening the daemon's services. The layout is checked
against Rust's `size_of`/`offset_of` by tests/tests/python_consumer.rs.
"""

import ctypes

V3 = ctypes.c_double * 3
V4 = ctypes.c_double * 4

# solution_flags
FLAG_ALIGNED = 1 << 0
FLAG_SRS_FRESH = 1 << 1
FLAG_CNS_FRESH = 1 << 2
FLAG_BARO_FRESH = 1 << 3
FLAG_LAST_INNOVATION_REJECTED = 1 << 4
FLAG_IMU_LOST = 1 << 5
FLAG_COASTING = 1 << 6
FLAG_RESUMED = 1 << 7
FLAG_AID_RESET = 1 << 8
FLAG_STAR_FRESH = 1 << 9
FLAG_SECOND_PUBLISHER = 1 << 10
FLAG_GNSS_FRESH = 1 << 11
FLAG_GNSS_EXCLUDED = 1 << 12
FLAG_BASELINE_FRESH = 1 << 13
FLAG_MAG_FRESH = 1 << 14
# Paper 003 §4.5: the flight state (0 unknown, 1 ground, 2 steady, 3
# manoeuvre) and a level fused from the accelerometers.
FLAG_FLIGHT_STATE_SHIFT = 15
FLAG_FLIGHT_STATE_MASK = 0b11 << FLAG_FLIGHT_STATE_SHIFT
FLAG_LEVEL_FUSED = 1 << 17
# GNSS fused untested: its integrity test is unavailable (the autonomous
# solution's horizontal protection level beyond the alert limit).
FLAG_GNSS_UNTESTED = 1 << 18

# AidStatus.integrity_state: could the integrity test judge the last sample.
INTEGRITY_NOT_TESTED = 0
INTEGRITY_TESTED = 1
INTEGRITY_UNAVAILABLE = 2

# InitState.method and Status.init_method: how the attitude was found.
INIT_GIVEN = 0
INIT_GYROCOMPASS = 1
INIT_AID_HEADING = 2

# WireFrame
FRAME_GEOGRAPHIC = 0
FRAME_GRID = 1

# The aids, in the order of Status.aids (the Rust declaration's, msgs/src/aids.rs:
# the layout test holds this tuple to it). Status.streams has the IMU first.
AIDS = ("srs", "cns", "baro", "star", "gnss", "baseline", "mag")
AID_COUNT = len(AIDS)
STREAM_COUNT = AID_COUNT + 1
MAX_COMPONENTS = 6
MAX_CAUSES = 4


class Solution(ctypes.Structure):
    """Full navigation solution, one per filter cycle (`polarnav/solution`)."""

    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("lat_rad", ctypes.c_double),
        ("lon_rad", ctypes.c_double),
        ("h_m", ctypes.c_double),
        ("r_e_m", V3),
        ("v_e_mps", V3),
        ("v_enu_mps", V3),
        ("v_nav_mps", V3),
        ("grid_angle_rad", ctypes.c_double),
        ("q_b_e", V4),
        ("heading_rad", ctypes.c_double),
        ("grid_heading_rad", ctypes.c_double),
        ("pitch_rad", ctypes.c_double),
        ("roll_rad", ctypes.c_double),
        ("sigma_pos_enu_m", V3),
        ("sigma_vel_mps", V3),
        ("sigma_att_rad", V3),
        ("gyro_bias_rps", V3),
        ("accel_bias_mps2", V3),
        ("sigma_gyro_bias_rps", V3),
        ("sigma_accel_bias_mps2", V3),
        ("reset_t_ns", ctypes.c_uint64),
        ("reset_delta_pos_e_m", V3),
        ("reset_delta_vel_e_mps", V3),
        ("reset_delta_heading_rad", ctypes.c_double),
        ("flags", ctypes.c_uint32),
        ("switch_count", ctypes.c_uint32),
        ("reset_count", ctypes.c_uint32),
        ("frame", ctypes.c_uint8),
        ("_pad", ctypes.c_uint8 * 3),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::Solution_v3"


class StreamCounters(ctypes.Structure):
    """Counters of one input stream."""

    _fields_ = [
        ("received", ctypes.c_uint64),
        ("accepted", ctypes.c_uint64),
        ("rejected_invalid", ctypes.c_uint64),
        ("rejected_time", ctypes.c_uint64),
        ("rejected_gate", ctypes.c_uint64),
        ("rejected_integrity", ctypes.c_uint64),
        ("not_used", ctypes.c_uint64),
        ("seq_gaps", ctypes.c_uint64),
        ("last_t_ns", ctypes.c_uint64),
        ("refused_publisher", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::StreamCounters_v4"


class AidStatus(ctypes.Structure):
    """Status of one aid (the same record for every aid)."""

    _fields_ = [
        ("innovation", ctypes.c_double * MAX_COMPONENTS),
        ("innovation_var", ctypes.c_double * MAX_COMPONENTS),
        ("test_ratio", ctypes.c_double),
        ("last_fuse_t_ns", ctypes.c_uint64),
        ("exclusions", ctypes.c_uint64),
        # An aid that is not autonomous (GNSS): its integrity test.
        ("integrity_ratio", ctypes.c_double),
        ("excluded_since_t_ns", ctypes.c_uint64),
        # Samples refused before fusion, by the aid's causes (first: invalid content).
        ("refused", ctypes.c_uint64 * MAX_CAUSES),
        ("fused", ctypes.c_uint8),
        ("fresh", ctypes.c_uint8),
        # The frame the last innovation was made in: 1 + WireFrame (1 geographic,
        # 2 grid), 0 = not known (no update yet, or a daemon before this field).
        ("made_in_frame", ctypes.c_uint8),
        ("excluded", ctypes.c_uint8),
        ("exclusion_cause", ctypes.c_uint8),
        ("integrity_state", ctypes.c_uint8),
        ("_pad", ctypes.c_uint8 * 2),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::AidStatus_v3"


class Status(ctypes.Structure):
    """Health of the daemon, 1 Hz (`polarnav/status`)."""

    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        # streams[0] the IMU's counters, streams[1 + k] aid k's (k an index of AIDS).
        ("streams", StreamCounters * STREAM_COUNT),
        ("aids", AidStatus * AID_COUNT),
        ("cycles", ctypes.c_uint64),
        ("overruns", ctypes.c_uint64),
        ("overruns_cpu", ctypes.c_uint64),
        ("cycle_time_mean_ns", ctypes.c_uint64),
        ("cycle_time_max_ns", ctypes.c_uint64),
        ("last_switch_t_ns", ctypes.c_uint64),
        ("imu_gap_count", ctypes.c_uint64),
        ("coasted_ns", ctypes.c_uint64),
        ("checkpoints_written", ctypes.c_uint64),
        ("reinit_count", ctypes.c_uint32),
        ("switch_count", ctypes.c_uint32),
        ("reset_count", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("frame", ctypes.c_uint8),
        ("resumed", ctypes.c_uint8),
        # How the attitude of the navigator's init was found: 0 given
        # (INIT_GIVEN), 1 gyrocompassing, 2 an aid's heading (AIDS index in
        # init_heading_aid).
        ("init_method", ctypes.c_uint8),
        ("init_heading_aid", ctypes.c_uint8),
        # Services the daemon cannot open now: bit 0 the IMU, 1 + k aid k,
        # then init, solution, status, settings; bit 16 + b: service b exists
        # with another payload type or other options (msgs::unavailable).
        ("unavailable", ctypes.c_uint32),
    ]

    @property
    def imu(self) -> StreamCounters:
        return self.streams[0]

    def counters(self, aid: str) -> StreamCounters:
        """The counters of the aid named `aid`."""
        return self.streams[1 + AIDS.index(aid)]

    def aid(self, aid: str) -> AidStatus:
        """The status of the aid named `aid`."""
        return self.aids[AIDS.index(aid)]

    @staticmethod
    def type_name() -> str:
        return "polarnav::Status_v7"


class StarSample(ctypes.Structure):
    """Star tracker attitude, body->inertial (`polarnav/star`), for a Python sensor driver."""

    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("q_b_i", V4),
        ("boresight_b", V3),
        ("sigma_cross_arcsec", ctypes.c_double),
        ("sigma_boresight_arcsec", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::StarSample_v1"


class GnssFix(ctypes.Structure):
    """One GNSS fix of the antenna (`polarnav/gnss`): UBX-NAV-PVT's content in
    SI units, for a Python receiver driver. fix_type 3 (3D) or 4 (GNSS + dead
    reckoning) with flags bit 0 (gnssFixOK) set is a usable fix; flags bit 7
    (no velocity) marks a position-only source, whose position alone is fused."""

    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("lat_rad", ctypes.c_double),
        ("lon_rad", ctypes.c_double),
        ("height_m", ctypes.c_double),
        ("vel_ned_mps", V3),
        ("h_acc_m", ctypes.c_double),
        ("v_acc_m", ctypes.c_double),
        ("s_acc_mps", ctypes.c_double),
        ("pdop", ctypes.c_double),
        ("itow_ms", ctypes.c_uint32),
        ("fix_type", ctypes.c_uint8),
        ("num_sv", ctypes.c_uint8),
        ("flags", ctypes.c_uint8),
        ("_pad", ctypes.c_uint8),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::GnssFix_v1"


# BaselineSample.carr_soln
CARR_SOLN_NONE = 0
CARR_SOLN_FLOAT = 1
CARR_SOLN_FIXED = 2

# BaselineSample.flags (NAV-RELPOSNED flags without carrSoln, packed)
BASELINE_GNSS_FIX_OK = 1 << 0
BASELINE_DIFF_SOLN = 1 << 1
BASELINE_REL_POS_VALID = 1 << 2
BASELINE_IS_MOVING = 1 << 3
BASELINE_REF_POS_MISS = 1 << 4
BASELINE_REF_OBS_MISS = 1 << 5
BASELINE_HEADING_VALID = 1 << 6
BASELINE_NORMALIZED = 1 << 7


class BaselineSample(ctypes.Structure):
    """One baseline of a moving-base receiver (`polarnav/baseline`): UBX-NAV-RELPOSNED's
    content in SI units, the vector from the primary (moving-base) antenna to the
    secondary, north-east-down in the axes of (lat_rad, lon_rad), the receiver's fix
    of the same epoch. carr_soln 2 (fixed) with REL_POS_VALID and GNSS_FIX_OK set is
    a usable baseline."""

    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("lat_rad", ctypes.c_double),
        ("lon_rad", ctypes.c_double),
        ("rel_pos_ned_m", V3),
        ("length_m", ctypes.c_double),
        ("heading_rad", ctypes.c_double),
        ("acc_heading_rad", ctypes.c_double),
        ("acc_ned_m", V3),
        ("itow_ms", ctypes.c_uint32),
        ("carr_soln", ctypes.c_uint8),
        ("flags", ctypes.c_uint8),
        ("_pad", ctypes.c_uint16),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::BaselineSample_v1"


class MagSample(ctypes.Structure):
    """One magnetometer sample (`polarnav/mag`): the raw field in body axes
    (x right, y forward, z up) in nT, hard and soft iron still in it (the
    navigator calibrates it from its [aids.mag] settings), and the 1-sigma
    white noise of each axis (nT)."""

    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("field_b_nt", V3),
        ("sigma_nt", V3),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::MagSample_v1"


class ImuSample(ctypes.Structure):
    """Increments over `dt_s` ending at `t_ns` (body axes)."""

    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("dt_s", ctypes.c_double),
        ("d_theta_rad", V3),
        ("d_v_mps", V3),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::ImuSample_v1"


SRS_MAX_LINES = 8


class SrsLine(ctypes.Structure):
    _fields_ = [
        ("los_i", V3),
        ("body_vel_i_mps", V3),
        ("rest_wavelength_m", ctypes.c_double),
        ("measured_wavelength_m", ctypes.c_double),
        ("sigma_mps", ctypes.c_double),
        ("body_id", ctypes.c_uint32),
        ("_pad", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::SrsLine_v1"


class SrsSample(ctypes.Structure):
    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("count", ctypes.c_uint32),
        ("_pad", ctypes.c_uint32),
        ("lines", SrsLine * SRS_MAX_LINES),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::SrsSample_v1"


class CnsFix(ctypes.Structure):
    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("lat_rad", ctypes.c_double),
        ("lon_rad", ctypes.c_double),
        ("sigma_h_m", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::CnsFix_v1"


class BaroSample(ctypes.Structure):
    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("pressure_pa", ctypes.c_double),
        ("temperature_k", ctypes.c_double),
        ("sigma_m", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::BaroSample_v1"


class InitState(ctypes.Structure):
    _fields_ = [
        ("t_ns", ctypes.c_uint64),
        ("seq", ctypes.c_uint64),
        ("r_e_m", V3),
        ("v_e_mps", V3),
        ("q_b_e", V4),
        ("sigma_pos_h_m", ctypes.c_double),
        ("sigma_pos_v_m", ctypes.c_double),
        ("sigma_vel_h_mps", ctypes.c_double),
        ("sigma_vel_v_mps", ctypes.c_double),
        ("sigma_tilt_rad", ctypes.c_double),
        ("sigma_heading_rad", ctypes.c_double),
        ("method", ctypes.c_uint8),
        ("heading_aid", ctypes.c_uint8),
        ("_pad", ctypes.c_uint8 * 6),
    ]

    @staticmethod
    def type_name() -> str:
        return "polarnav::InitState_v2"


# The payload of each input stream, by its service's last name component.
INPUTS = {
    "imu": ImuSample,
    "init": InitState,
    "srs": SrsSample,
    "cns": CnsFix,
    "baro": BaroSample,
    "star": None,  # set below, once every aid class exists
    "gnss": None,
    "baseline": None,
    "mag": None,
}

# The quality of service of every service (polarnav_ipc::qos, the one table
# of the Rust side: msgs/ipc/src/lib.rs; the layout test holds these values
# to it). iceoryx2 fixes a service's QoS when the first process creates it,
# so a Python publisher that creates a service must ask for exactly these.
QOS = {
    # stream: (subscriber_max_buffer_size, history_size, safe_overflow)
    "imu": (500, 0, False),
    "aid": (25, 0, False),
    "init": (4, 1, True),
    "solution": (2000, 0, True),
    "status": (16, 1, True),
    "settings": (2, 1, True),
}
MAX_PUBLISHERS = 4
MAX_SUBSCRIBERS = 16
MAX_NODES = 32
EVENT_MAX_NOTIFIERS = 8
EVENT_MAX_LISTENERS = 16


def qos(stream: str):
    """(buffer, history, safe overflow) of a stream's service."""
    return QOS["aid"] if stream in AIDS else QOS[stream]


def layout() -> dict:
    """Sizes and field offsets, for the layout test."""
    out = {}
    for t in (Solution, StreamCounters, AidStatus, Status, StarSample, GnssFix, BaselineSample, MagSample,
              ImuSample, SrsLine, SrsSample, CnsFix, BaroSample, InitState):
        out[t.__name__] = ctypes.sizeof(t)
        for name, _ in t._fields_:
            out[f"{t.__name__}.{name}"] = getattr(t, name).offset
    for k, name in enumerate(AIDS):
        out[f"aid.{name}"] = k
    for stream in ("imu", "aid", "init", "solution", "status", "settings"):
        buffer, history, overflow = QOS[stream]
        out[f"qos.{stream}.buffer"] = buffer
        out[f"qos.{stream}.history"] = history
        out[f"qos.{stream}.safe_overflow"] = int(overflow)
    out["qos.max_publishers"] = MAX_PUBLISHERS
    out["qos.max_subscribers"] = MAX_SUBSCRIBERS
    out["qos.max_nodes"] = MAX_NODES
    out["qos.event_max_notifiers"] = EVENT_MAX_NOTIFIERS
    out["qos.event_max_listeners"] = EVENT_MAX_LISTENERS
    return out


INPUTS.update({"star": StarSample, "gnss": GnssFix, "baseline": BaselineSample, "mag": MagSample})
