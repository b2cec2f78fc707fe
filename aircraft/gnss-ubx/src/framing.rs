//! UBX framing: finds the frames in a byte stream and classifies every
//! byte that is not part of a good frame, by cause.
//!
//! A frame is `B5 62 class id len(u16 LE) payload[len] ck_a ck_b`, the
//! checksum an 8-bit Fletcher over class to the end of the payload.
//!
//! Written here rather than taken from the `ublox` crate's `Parser`
//! (which decodes the payloads for us, `crate::decode`): its streaming
//! parser drops bytes between frames without saying how many, and reports
//! a frame cut short by the next one as a checksum error, so it cannot
//! give the per-cause counts this driver reports. The rules:
//!
//! - bytes before a sync pair `B5 62` are **garbage** (counted in bytes);
//! - a header whose length exceeds [`MAX_PAYLOAD`] is **oversize**: its
//!   two sync bytes are dropped and the search goes on after them;
//! - a frame whose checksum fails is **truncated** when another sync pair
//!   starts inside it (it was cut short by the next frame, which is then
//!   parsed), else a **bad checksum** (the whole frame is dropped);
//! - a frame still incomplete while a complete frame with a good checksum
//!   already starts inside it is **truncated** at once, so one cut frame
//!   never delays the good frames behind it until its declared length has
//!   arrived;
//! - what is left when the device goes away or the file ends is one
//!   truncated frame (if it starts with a sync pair) or garbage.
//!
//! Bounded work: each byte is examined a bounded number of times, the
//! buffer never holds more than one frame of [`MAX_PAYLOAD`] plus one read.

/// First and second sync characters.
pub const SYNC: [u8; 2] = [0xB5, 0x62];
/// Sync, class, id and length.
pub const HEADER_LEN: usize = 6;
/// Largest payload taken as a frame (bytes): u-blox's longest messages
/// (RXM-RAWX with 255 measurements, 8176 bytes) fit.
pub const MAX_PAYLOAD: usize = 8192;

/// One frame with a good checksum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    /// Message class.
    pub class: u8,
    /// Message id within the class.
    pub id: u8,
    /// The payload (without header and checksum).
    pub payload: &'a [u8],
}

/// What the framer has seen, by cause.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameCounters {
    /// Frames with a good checksum.
    pub frames: u64,
    /// Complete frames whose checksum failed.
    pub bad_checksum: u64,
    /// Frames cut short (by the next frame, the end of the file or the
    /// loss of the device).
    pub truncated: u64,
    /// Headers declaring more than [`MAX_PAYLOAD`] bytes.
    pub oversize: u64,
    /// Bytes outside any frame.
    pub garbage_bytes: u64,
}

/// The 8-bit Fletcher checksum of UBX over `bytes` (class to payload end).
pub fn checksum(bytes: &[u8]) -> [u8; 2] {
    let (mut a, mut b) = (0u8, 0u8);
    for &x in bytes {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    [a, b]
}

/// Finds UBX frames in a stream fed in pieces of any size.
#[derive(Debug, Default)]
pub struct Framer {
    buf: Vec<u8>,
    counters: FrameCounters,
}

/// The first sync pair in `b`, or where a trailing first sync byte starts.
fn find_sync(b: &[u8]) -> Option<usize> {
    (0..b.len()).find(|&i| b[i] == SYNC[0] && b.get(i + 1).is_none_or(|&c| c == SYNC[1]))
}

/// The declared total length of the frame starting at `b[0]` (a sync pair),
/// if its header is there.
fn declared_total(b: &[u8]) -> Option<usize> {
    (b.len() >= HEADER_LEN).then(|| usize::from(u16::from_le_bytes([b[4], b[5]])) + HEADER_LEN + 2)
}

/// Whether `b` starts with a complete frame with a good checksum.
fn complete_and_good(b: &[u8]) -> bool {
    if b.len() < 2 || b[..2] != SYNC {
        return false;
    }
    match declared_total(b) {
        Some(total) if total - HEADER_LEN - 2 <= MAX_PAYLOAD && b.len() >= total => {
            checksum(&b[2..total - 2]) == [b[total - 2], b[total - 1]]
        }
        _ => false,
    }
}

impl Framer {
    /// A framer with nothing held.
    pub fn new() -> Self {
        Self::default()
    }

    /// What it has seen so far.
    pub fn counters(&self) -> FrameCounters {
        self.counters
    }

    /// Bytes held for an incomplete frame.
    pub fn pending(&self) -> usize {
        self.buf.len()
    }

    /// Appends `data` and hands every complete good frame to `on_frame`, in order.
    pub fn push(&mut self, data: &[u8], mut on_frame: impl FnMut(Frame<'_>)) {
        self.buf.extend_from_slice(data);
        let mut pos = 0;
        let c = &mut self.counters;
        loop {
            let rest = &self.buf[pos..];
            match find_sync(rest) {
                None => {
                    c.garbage_bytes += rest.len() as u64;
                    pos = self.buf.len();
                    break;
                }
                Some(k) => {
                    c.garbage_bytes += k as u64;
                    pos += k;
                }
            }
            let rest = &self.buf[pos..];
            let Some(total) = declared_total(rest) else {
                break; // wait for the header
            };
            if total - HEADER_LEN - 2 > MAX_PAYLOAD {
                c.oversize += 1;
                pos += 2;
                continue;
            }
            if rest.len() >= total {
                let good = checksum(&rest[2..total - 2]) == [rest[total - 2], rest[total - 1]];
                if !good && rest.len() == total && rest[total - 1] == SYNC[0] {
                    // Its last byte may start the next frame: wait for one more.
                    break;
                }
                if good {
                    c.frames += 1;
                    on_frame(Frame {
                        class: rest[2],
                        id: rest[3],
                        payload: &rest[HEADER_LEN..total - 2],
                    });
                    pos += total;
                } else if let Some(k) =
                    (2..total).find(|&i| rest[i] == SYNC[0] && rest.get(i + 1) == Some(&SYNC[1]))
                {
                    c.truncated += 1;
                    pos += k;
                } else {
                    c.bad_checksum += 1;
                    pos += total;
                }
                continue;
            }
            // Incomplete: cut short if a good frame already starts inside it.
            match (2..rest.len()).find(|&i| rest[i] == SYNC[0] && complete_and_good(&rest[i..])) {
                Some(k) => {
                    c.truncated += 1;
                    pos += k;
                }
                None => break,
            }
        }
        self.buf.drain(..pos);
    }

    /// The stream ended (end of file, device lost): what is held is one
    /// truncated frame or garbage. The framer starts afresh.
    pub fn finish(&mut self) {
        if self.buf.len() >= 2 && self.buf[..2] == SYNC {
            self.counters.truncated += 1;
        } else {
            self.counters.garbage_bytes += self.buf.len() as u64;
        }
        self.buf.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
        let mut f = vec![SYNC[0], SYNC[1], class, id];
        f.extend_from_slice(&(payload.len() as u16).to_le_bytes());
        f.extend_from_slice(payload);
        let ck = checksum(&f[2..]);
        f.extend_from_slice(&ck);
        f
    }

    fn run(stream: &[u8], piece: usize) -> (Vec<(u8, u8, Vec<u8>)>, FrameCounters) {
        let mut fr = Framer::new();
        let mut got = Vec::new();
        for chunk in stream.chunks(piece.max(1)) {
            fr.push(chunk, |f| got.push((f.class, f.id, f.payload.to_vec())));
        }
        fr.finish();
        (got, fr.counters())
    }

    #[test]
    fn the_checksum_is_ubx_fletcher() {
        // UBX-CFG-RATE poll, as printed in the u-blox interface description.
        let f = frame(0x06, 0x08, &[]);
        assert_eq!(f, [0xB5, 0x62, 0x06, 0x08, 0x00, 0x00, 0x0E, 0x30]);
    }

    #[test]
    fn every_kind_of_damage_is_counted_once_and_good_frames_survive_it_in_any_read_size() {
        let good = |n: u8| frame(0x01, 0x07, &[n; 92]);
        let mut stream = Vec::new();
        stream.extend(good(1));
        stream.extend([0x00, 0x11, 0x24]); // garbage
        let mut bad = good(2);
        bad[20] ^= 0x40;
        stream.extend(&bad); // bad checksum
        stream.extend(&good(3)[..50]); // truncated by the next frame
        stream.extend(good(4));
        stream.extend([0xB5, 0x62, 0x01, 0x07, 0xFF, 0xFF]); // oversize: 2 sync + 4 garbage
        stream.extend(frame(0x0A, 0x09, &[7; 60])); // another class
        stream.extend(&good(5)[..30]); // truncated by the end of the stream
        for piece in [1, 2, 7, 64, 4096] {
            let (got, c) = run(&stream, piece);
            let ids: Vec<(u8, u8, u8)> = got.iter().map(|(a, b, p)| (*a, *b, p[0])).collect();
            assert_eq!(
                ids,
                [(1, 7, 1), (1, 7, 4), (0x0A, 0x09, 7)],
                "read size {piece}"
            );
            assert_eq!(
                c,
                FrameCounters {
                    frames: 3,
                    bad_checksum: 1,
                    truncated: 2,
                    oversize: 1,
                    garbage_bytes: 3 + 4,
                },
                "read size {piece}"
            );
        }
    }

    #[test]
    fn a_cut_frame_declaring_a_long_payload_does_not_delay_the_next_good_frame() {
        // The cut header claims 8000 bytes; the good frame behind it is
        // handed over as soon as it is complete, not 8000 bytes later.
        let mut fr = Framer::new();
        let mut got = 0;
        fr.push(&[0xB5, 0x62, 0x02, 0x15, 0x40, 0x1F, 1, 2, 3], |_| got += 1);
        fr.push(&frame(0x01, 0x07, &[9; 92]), |_| got += 1);
        assert_eq!(got, 1);
        assert_eq!(fr.counters().truncated, 1);
        assert_eq!(fr.pending(), 0);
    }

    #[test]
    fn sync_bytes_inside_a_good_payload_are_payload() {
        let f = frame(0x01, 0x07, &[0xB5, 0x62, 0x01, 0x07, 0x00, 0x00, 0xB5]);
        let (got, c) = run(&f, 3);
        assert_eq!(got.len(), 1);
        assert_eq!(c.frames, 1);
        assert_eq!(
            c.garbage_bytes + c.truncated + c.bad_checksum + c.oversize,
            0
        );
    }

    #[test]
    fn pure_noise_is_garbage_and_the_buffer_stays_small() {
        let noise: Vec<u8> = (0..100_000u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        let mut fr = Framer::new();
        let mut frames = 0;
        for chunk in noise.chunks(1000) {
            fr.push(chunk, |_| frames += 1);
            assert!(fr.pending() <= MAX_PAYLOAD + 8 + 1000);
        }
        fr.finish();
        let c = fr.counters();
        // Every byte is accounted for: garbage, or inside a judged candidate.
        assert!(c.garbage_bytes > 90_000, "{c:?}");
        assert_eq!(fr.pending(), 0);
    }
}
