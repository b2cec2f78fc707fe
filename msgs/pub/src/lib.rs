//! libpolarnav_pub: the C ABI of polarnav's input publishers, so that a
//! sensor driver written in C or C++ publishes its IMU, an aid or the
//! initial state into the daemon as the Rust drivers do (`gnss-ubx`,
//! `sensor-replay play`).
//!
//! One opaque publisher per input stream ([`pn_publisher_open`]), one
//! function per payload ([`pn_publish_imu`], [`pn_publish_gnss`], ...),
//! [`pn_publisher_lost`] and [`pn_publisher_close`]. It uses the services
//! the Rust side builds (`polarnav_ipc`: the same QoS table, the same
//! paired event service, the same prefix rule and the environment
//! `POLARNAV_IOX_ROOT` / `POLARNAV_IOX_PREFIX`) with the in-flight
//! delivery: a full subscriber buffer drops the sample for that subscriber
//! and counts it, the call never blocks.
//!
//! Every function returns a code ([`PnCode`]): 0 for done, a negative
//! error (nothing was published), or a positive warning (done, but look).
//! [`pn_error_name`] and [`pn_error_message`] say what a code means;
//! [`pn_last_error_detail`] what the last failure of the calling thread
//! was in words (the iceoryx2 error, the field). A sample with a NaN or an
//! infinity, or whose stamp is not after the previous one, is refused at
//! the call and counted ([`pn_publisher_refused`]). No function panics
//! across the ABI: a panic inside becomes [`PnCode::PN_E_INTERNAL`].
//!
//! The header is `msgs/include/polarnav_pub.h` (cbindgen, checked by CI),
//! beside `polarnav_msgs.h` that declares the payloads.

// A C ABI takes raw pointers: each `unsafe` block below says why it holds.
#![allow(unsafe_code)]

use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char};
use std::fmt::Debug;
use std::panic::{AssertUnwindSafe, catch_unwind};

use iceoryx2::prelude::*;
use msgs::service::{DEFAULT_PREFIX, Topic, validate_prefix};
use msgs::{
    AidKind, AidPayload, BaroSample, BaselineSample, CnsFix, GnssFix, ImuSample, InitState,
    MagSample, SrsSample, StarSample,
};
use polarnav_ipc::{Delivery, TopicPublisher, TransportConfig, TransportError};

/// What a call did. 0: done; negative: an error, nothing published;
/// positive: a warning, done.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum PnCode {
    /// Done.
    PN_OK = 0,
    /// A null pointer where a publisher, a sample or a stream name was due.
    PN_E_NULL = -1,
    /// The prefix breaks the prefix rule (1 to 64 of `A-Z a-z 0-9 _ - .`
    /// in `/`-separated parts) or is not UTF-8.
    PN_E_BAD_PREFIX = -2,
    /// The stream is none of `imu`, `init` and the aids' names.
    PN_E_UNKNOWN_STREAM = -3,
    /// The service exists with another payload type or other options (a
    /// process of another version, or a squatter, created it first).
    PN_E_INCOMPATIBLE_SERVICE = -4,
    /// iceoryx2 failed otherwise (no shared memory, too many ports, ...):
    /// see [`pn_last_error_detail`].
    PN_E_TRANSPORT = -5,
    /// A float of the sample is NaN or infinite: refused and counted.
    PN_E_NOT_FINITE = -6,
    /// The sample's stamp is not after the previous one's: refused and counted.
    PN_E_STAMP_NOT_INCREASING = -7,
    /// The payload is not the publisher's stream's (`pn_publish_gnss` on
    /// an `imu` publisher).
    PN_E_WRONG_STREAM = -8,
    /// A panic inside the library (a bug): see [`pn_last_error_detail`].
    PN_E_INTERNAL = -9,
    /// Opened, but the service already had a publisher: the daemon takes
    /// the first publisher's samples and refuses (and counts) the others'.
    PN_W_SECOND_PUBLISHER = 1,
}

impl PnCode {
    const ALL: [PnCode; 11] = [
        PnCode::PN_OK,
        PnCode::PN_E_NULL,
        PnCode::PN_E_BAD_PREFIX,
        PnCode::PN_E_UNKNOWN_STREAM,
        PnCode::PN_E_INCOMPATIBLE_SERVICE,
        PnCode::PN_E_TRANSPORT,
        PnCode::PN_E_NOT_FINITE,
        PnCode::PN_E_STAMP_NOT_INCREASING,
        PnCode::PN_E_WRONG_STREAM,
        PnCode::PN_E_INTERNAL,
        PnCode::PN_W_SECOND_PUBLISHER,
    ];

    fn from_i32(c: i32) -> Option<Self> {
        Self::ALL.into_iter().find(|k| *k as i32 == c)
    }

    /// Name and message, NUL-terminated.
    fn text(self) -> (&'static CStr, &'static CStr) {
        match self {
            PnCode::PN_OK => (c"PN_OK", c"done"),
            PnCode::PN_E_NULL => (c"PN_E_NULL", c"a null pointer was passed"),
            PnCode::PN_E_BAD_PREFIX => (
                c"PN_E_BAD_PREFIX",
                c"the service prefix breaks the prefix rule (1 to 64 of A-Z a-z 0-9 _ - . in /-separated parts)",
            ),
            PnCode::PN_E_UNKNOWN_STREAM => (
                c"PN_E_UNKNOWN_STREAM",
                c"unknown stream (imu, init, or an aid's name: pn_aid_name)",
            ),
            PnCode::PN_E_INCOMPATIBLE_SERVICE => (
                c"PN_E_INCOMPATIBLE_SERVICE",
                c"the service exists with another payload type or other options",
            ),
            PnCode::PN_E_TRANSPORT => (c"PN_E_TRANSPORT", c"iceoryx2 failed"),
            PnCode::PN_E_NOT_FINITE => (
                c"PN_E_NOT_FINITE",
                c"a float of the sample is NaN or infinite: refused",
            ),
            PnCode::PN_E_STAMP_NOT_INCREASING => (
                c"PN_E_STAMP_NOT_INCREASING",
                c"the sample's stamp is not after the previous one's: refused",
            ),
            PnCode::PN_E_WRONG_STREAM => (
                c"PN_E_WRONG_STREAM",
                c"the payload is not the publisher's stream's",
            ),
            PnCode::PN_E_INTERNAL => (c"PN_E_INTERNAL", c"internal error (a bug in the library)"),
            PnCode::PN_W_SECOND_PUBLISHER => (
                c"PN_W_SECOND_PUBLISHER",
                c"opened, but the service already has a publisher: the daemon refuses this one's samples",
            ),
        }
    }
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_detail(text: &str) {
    let c = CString::new(text.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

/// An error code with its detail for [`pn_last_error_detail`].
fn fail(code: PnCode, detail: &str) -> PnCode {
    set_detail(detail);
    code
}

/// The port of one stream.
#[derive(Debug)]
enum Port {
    Imu(TopicPublisher<ImuSample>),
    Init(TopicPublisher<InitState>),
    Aid(AidKind, Box<dyn polarnav_ipc::AidPublisher>),
}

/// An open publisher of one input stream (opaque to C).
#[derive(Debug)]
pub struct PnPublisher {
    // Field order is drop order: the port before its node.
    port: Port,
    _node: Node<ipc::Service>,
    stream: &'static str,
    last_t_ns: Option<u64>,
    sent: u64,
    refused: u64,
}

fn stream_topic(name: &str) -> Option<(Topic, &'static str)> {
    match name {
        "imu" => Some((Topic::Imu, "imu")),
        "init" => Some((Topic::Init, "init")),
        _ => AidKind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .map(|k| (Topic::Aid(k), k.name())),
    }
}

fn transport_code(e: &TransportError) -> PnCode {
    let text = e.to_string();
    if text.contains("Incompatible") || text.contains("DoesNotSupport") {
        PnCode::PN_E_INCOMPATIBLE_SERVICE
    } else {
        PnCode::PN_E_TRANSPORT
    }
}

/// Publishers connected to the service of `topic` before this one.
fn publishers_of<T: Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    cfg: &TransportConfig,
    topic: Topic,
) -> Result<usize, TransportError> {
    use iceoryx2::service::port_factory::PortFactory as _;
    Ok(polarnav_ipc::pubsub_service::<T>(node, cfg, topic)?
        .dynamic_config()
        .number_of_publishers())
}

fn open(prefix: Option<&str>, stream: &str) -> Result<(PnPublisher, PnCode), PnCode> {
    let prefix = prefix.unwrap_or(DEFAULT_PREFIX);
    validate_prefix(prefix).map_err(|why| fail(PnCode::PN_E_BAD_PREFIX, &why))?;
    let (topic, stream) = stream_topic(stream).ok_or_else(|| {
        fail(
            PnCode::PN_E_UNKNOWN_STREAM,
            &format!("unknown stream {stream:?}"),
        )
    })?;
    let cfg = TransportConfig::new(prefix);
    let err = |e: TransportError| fail(transport_code(&e), &e.to_string());
    let node = polarnav_ipc::node(&cfg, &format!("driver-{stream}")).map_err(err)?;
    let (others, port) = match topic {
        Topic::Imu => (
            publishers_of::<ImuSample>(&node, &cfg, topic).map_err(err)?,
            Port::Imu(
                TopicPublisher::with_delivery(&node, &cfg, topic, Delivery::Discard)
                    .map_err(err)?,
            ),
        ),
        Topic::Init => (
            publishers_of::<InitState>(&node, &cfg, topic).map_err(err)?,
            Port::Init(
                TopicPublisher::with_delivery(&node, &cfg, topic, Delivery::Discard)
                    .map_err(err)?,
            ),
        ),
        Topic::Aid(k) => msgs::match_aid_kind!(k, P => {
            let others = publishers_of::<P>(&node, &cfg, topic).map_err(err)?;
            let p: Box<dyn polarnav_ipc::AidPublisher> = Box::new(
                TopicPublisher::<P>::with_delivery(&node, &cfg, topic, Delivery::Discard)
                    .map_err(err)?,
            );
            (others, Port::Aid(k, p))
        }),
        _ => return Err(fail(PnCode::PN_E_UNKNOWN_STREAM, "not an input stream")),
    };
    let code = if others > 0 {
        set_detail(&format!(
            "{} already has {others} publisher(s): the daemon takes the first one's samples",
            topic.service_name(prefix)
        ));
        PnCode::PN_W_SECOND_PUBLISHER
    } else {
        PnCode::PN_OK
    };
    Ok((
        PnPublisher {
            port,
            _node: node,
            stream,
            last_t_ns: None,
            sent: 0,
            refused: 0,
        },
        code,
    ))
}

/// Runs `f`, a panic becoming [`PnCode::PN_E_INTERNAL`].
fn guarded(f: impl FnOnce() -> PnCode) -> i32 {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(c) => c as i32,
        Err(p) => {
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            fail(PnCode::PN_E_INTERNAL, &format!("panic: {msg}")) as i32
        }
    }
}

/// # Safety
/// `s` is null or a NUL-terminated string valid for the call.
unsafe fn str_arg<'a>(s: *const c_char) -> Option<Result<&'a str, std::str::Utf8Error>> {
    // SAFETY: the caller's contract.
    (!s.is_null()).then(|| unsafe { CStr::from_ptr(s) }.to_str())
}

/// Opens a publisher of `stream` (`"imu"`, `"init"` or an aid's name,
/// [`pn_aid_name`] of its `AidKind`)
/// under the service prefix `prefix` (NULL: `"polarnav"`, the daemon's
/// default). Writes the code to `*err` (when `err` is not NULL): 0, or
/// [`PnCode::PN_W_SECOND_PUBLISHER`] with a publisher that works but whose
/// samples the daemon refuses, or an error and NULL returned.
///
/// # Safety
/// `prefix` and `stream` are NULL or NUL-terminated strings; `err` is NULL
/// or points to an `int32_t`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publisher_open(
    prefix: *const c_char,
    stream: *const c_char,
    err: *mut i32,
) -> *mut PnPublisher {
    let mut out: *mut PnPublisher = std::ptr::null_mut();
    let code = guarded(|| {
        // SAFETY: the caller's contract on `prefix` and `stream`.
        let (prefix, stream) = unsafe { (str_arg(prefix), str_arg(stream)) };
        let prefix = match prefix {
            None => None,
            Some(Ok(p)) => Some(p),
            Some(Err(e)) => return fail(PnCode::PN_E_BAD_PREFIX, &format!("not UTF-8: {e}")),
        };
        let stream = match stream {
            None => return fail(PnCode::PN_E_NULL, "stream is NULL"),
            Some(Ok(s)) => s,
            Some(Err(e)) => {
                return fail(PnCode::PN_E_UNKNOWN_STREAM, &format!("not UTF-8: {e}"));
            }
        };
        match open(prefix, stream) {
            Ok((p, code)) => {
                out = Box::into_raw(Box::new(p));
                code
            }
            Err(code) => code,
        }
    });
    if !err.is_null() {
        // SAFETY: the caller's contract on `err`.
        unsafe { *err = code };
    }
    out
}

/// What a payload's stamp and finiteness are, for the checks of every call.
trait Stamped: serde::Serialize {
    fn stamp(&self) -> u64;
}

impl Stamped for ImuSample {
    fn stamp(&self) -> u64 {
        self.t_ns
    }
}

impl Stamped for InitState {
    fn stamp(&self) -> u64 {
        self.t_ns
    }
}

macro_rules! stamped_aids {
    ($($P:ty),*) => {
        $(impl Stamped for $P {
            fn stamp(&self) -> u64 {
                AidPayload::t_ns(self)
            }
        })*
    };
}
stamped_aids!(
    SrsSample,
    CnsFix,
    BaroSample,
    StarSample,
    GnssFix,
    BaselineSample,
    MagSample
);

impl PnPublisher {
    /// The checks every sample passes, then `send`.
    fn publish_checked<T: Stamped>(
        &mut self,
        sample: &T,
        send: impl FnOnce(&Port) -> Option<Result<usize, TransportError>>,
    ) -> PnCode {
        if let Some(field) = msgs::finite::first_non_finite(sample) {
            self.refused += 1;
            return fail(
                PnCode::PN_E_NOT_FINITE,
                &format!("{}.{field} is not finite", self.stream),
            );
        }
        let t = sample.stamp();
        if let Some(prev) = self.last_t_ns
            && t <= prev
        {
            self.refused += 1;
            return fail(
                PnCode::PN_E_STAMP_NOT_INCREASING,
                &format!("{}: stamp {t} ns after {prev} ns", self.stream),
            );
        }
        match send(&self.port) {
            None => fail(
                PnCode::PN_E_WRONG_STREAM,
                &format!("the payload is not a {} sample", self.stream),
            ),
            Some(Err(e)) => fail(transport_code(&e), &e.to_string()),
            Some(Ok(_)) => {
                self.last_t_ns = Some(t);
                self.sent += 1;
                PnCode::PN_OK
            }
        }
    }
}

/// # Safety
/// `p` is NULL or a publisher from [`pn_publisher_open`] not yet closed;
/// `sample` is NULL or points to a valid `T`.
unsafe fn publish_with<T: Stamped + Copy>(
    p: *mut PnPublisher,
    sample: *const T,
    send: impl FnOnce(&Port, &T) -> Option<Result<usize, TransportError>>,
) -> i32 {
    guarded(|| {
        if p.is_null() || sample.is_null() {
            return fail(PnCode::PN_E_NULL, "publisher or sample is NULL");
        }
        // SAFETY: the caller's contract: a live publisher used by one
        // thread at a time, and a readable sample (read unaligned: a C
        // caller may hand a packed buffer).
        let (publisher, s) = unsafe { (&mut *p, sample.read_unaligned()) };
        publisher.publish_checked(&s, |port| send(port, &s))
    })
}

/// Publishes an IMU sample (increments over `dt_s` ending at `t_ns`).
///
/// # Safety
/// `p` is a publisher from [`pn_publisher_open`] not yet closed (or NULL),
/// used by one thread at a time; `sample` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_imu(p: *mut PnPublisher, sample: *const ImuSample) -> i32 {
    // SAFETY: forwarded contract.
    unsafe {
        publish_with(p, sample, |port, s| match port {
            Port::Imu(x) => Some(x.publish(s)),
            _ => None,
        })
    }
}

/// Publishes the initial state (`init` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_init(p: *mut PnPublisher, sample: *const InitState) -> i32 {
    // SAFETY: forwarded contract.
    unsafe {
        publish_with(p, sample, |port, s| match port {
            Port::Init(x) => Some(x.publish(s)),
            _ => None,
        })
    }
}

// Written out, not by a macro: cbindgen does not expand macros.
/// # Safety
/// As [`pn_publish_imu`].
unsafe fn publish_aid<P: AidPayload + Stamped>(p: *mut PnPublisher, sample: *const P) -> i32 {
    // SAFETY: forwarded contract.
    unsafe {
        publish_with(p, sample, |port, s| match port {
            Port::Aid(k, x) if *k == P::KIND => Some(x.publish_sample(&(*s).into())),
            _ => None,
        })
    }
}

/// Publishes a star-spectra velocity sample (`srs` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_srs(p: *mut PnPublisher, sample: *const SrsSample) -> i32 {
    // SAFETY: forwarded contract.
    unsafe { publish_aid(p, sample) }
}

/// Publishes a celestial position fix (`cns` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_cns(p: *mut PnPublisher, sample: *const CnsFix) -> i32 {
    // SAFETY: forwarded contract.
    unsafe { publish_aid(p, sample) }
}

/// Publishes a barometer sample (`baro` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_baro(p: *mut PnPublisher, sample: *const BaroSample) -> i32 {
    // SAFETY: forwarded contract.
    unsafe { publish_aid(p, sample) }
}

/// Publishes a star-tracker attitude (`star` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_star(p: *mut PnPublisher, sample: *const StarSample) -> i32 {
    // SAFETY: forwarded contract.
    unsafe { publish_aid(p, sample) }
}

/// Publishes a GNSS fix (`gnss` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_gnss(p: *mut PnPublisher, sample: *const GnssFix) -> i32 {
    // SAFETY: forwarded contract.
    unsafe { publish_aid(p, sample) }
}

/// Publishes a dual-antenna baseline (`baseline` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_baseline(
    p: *mut PnPublisher,
    sample: *const BaselineSample,
) -> i32 {
    // SAFETY: forwarded contract.
    unsafe { publish_aid(p, sample) }
}

/// Publishes a magnetometer sample (`mag` publisher).
///
/// # Safety
/// As [`pn_publish_imu`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publish_mag(p: *mut PnPublisher, sample: *const MagSample) -> i32 {
    // SAFETY: forwarded contract.
    unsafe { publish_aid(p, sample) }
}

/// Deliveries dropped because a subscriber's buffer was full (one per
/// subscriber and sample; the daemon sees them as sequence gaps). 0 for NULL.
///
/// # Safety
/// `p` is NULL or a publisher from [`pn_publisher_open`] not yet closed.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publisher_lost(p: *const PnPublisher) -> u64 {
    // SAFETY: the caller's contract.
    match unsafe { p.as_ref() } {
        None => 0,
        Some(p) => match &p.port {
            Port::Imu(x) => x.lost(),
            Port::Init(x) => x.lost(),
            Port::Aid(_, x) => x.lost(),
        },
    }
}

/// Samples refused at the call (not finite, stamp not increasing). 0 for NULL.
///
/// # Safety
/// As [`pn_publisher_lost`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publisher_refused(p: *const PnPublisher) -> u64 {
    // SAFETY: the caller's contract.
    unsafe { p.as_ref() }.map_or(0, |p| p.refused)
}

/// Samples sent. 0 for NULL.
///
/// # Safety
/// As [`pn_publisher_lost`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publisher_sent(p: *const PnPublisher) -> u64 {
    // SAFETY: the caller's contract.
    unsafe { p.as_ref() }.map_or(0, |p| p.sent)
}

/// Closes the publisher and frees it (NULL: nothing).
///
/// # Safety
/// `p` is NULL or a publisher from [`pn_publisher_open`], closed once.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn pn_publisher_close(p: *mut PnPublisher) {
    if !p.is_null() {
        // SAFETY: the caller's contract: it came from Box::into_raw.
        let b = unsafe { Box::from_raw(p) };
        let _ = catch_unwind(AssertUnwindSafe(|| drop(b)));
    }
}

/// The stream name of the aid `kind` (an `AidKind`, `0 ..
/// POLARNAV_AID_COUNT`), from the aids' one declaration: the `stream` of
/// [`pn_publisher_open`] for it. NULL for any other value. A static string.
#[unsafe(no_mangle)]
pub extern "C" fn pn_aid_name(kind: u32) -> *const c_char {
    static NAMES: std::sync::OnceLock<Vec<CString>> = std::sync::OnceLock::new();
    let names = NAMES.get_or_init(|| {
        AidKind::ALL
            .into_iter()
            .map(|k| CString::new(k.name()).unwrap_or_default())
            .collect()
    });
    usize::try_from(kind)
        .ok()
        .and_then(|k| names.get(k))
        .map_or(std::ptr::null(), |n| n.as_ptr())
}

/// The name of a code (`"PN_E_NOT_FINITE"`), `"PN_UNKNOWN_CODE"` for any
/// other value. A static string.
#[unsafe(no_mangle)]
pub extern "C" fn pn_error_name(code: i32) -> *const c_char {
    PnCode::from_i32(code).map_or(c"PN_UNKNOWN_CODE".as_ptr(), |c| c.text().0.as_ptr())
}

/// What a code means, in words. A static string.
#[unsafe(no_mangle)]
pub extern "C" fn pn_error_message(code: i32) -> *const c_char {
    PnCode::from_i32(code).map_or(c"not a libpolarnav_pub code".as_ptr(), |c| {
        c.text().1.as_ptr()
    })
}

/// The detail of the calling thread's last error or warning (the iceoryx2
/// error, the field that was not finite, ...). Valid until the thread's
/// next call into the library.
#[unsafe(no_mangle)]
pub extern "C" fn pn_last_error_detail() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_has_its_own_name_and_a_message() {
        let mut names = std::collections::BTreeSet::new();
        for c in PnCode::ALL {
            let (n, m) = c.text();
            assert!(n.to_str().expect("ascii").starts_with("PN_"));
            assert!(!m.is_empty());
            assert!(names.insert(n), "{n:?} twice");
            assert_eq!(PnCode::from_i32(c as i32), Some(c));
        }
        assert_eq!(PnCode::from_i32(77), None);
    }

    #[test]
    fn aid_names_are_the_declarations() {
        for k in AidKind::ALL {
            let p = pn_aid_name(k as u32);
            assert!(!p.is_null());
            // SAFETY: a static NUL-terminated string of the library.
            let name = unsafe { CStr::from_ptr(p) }.to_str().expect("ascii");
            assert_eq!(name, k.name());
            assert_eq!(stream_topic(name).map(|t| t.0), Some(Topic::Aid(k)));
        }
        assert!(pn_aid_name(AidKind::ALL.len() as u32).is_null());
        assert!(pn_aid_name(u32::MAX).is_null());
    }
}
