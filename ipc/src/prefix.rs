//! Writing a fixed-capacity payload into a loaned sample, the entries in use only.
//!
//! [`BodyCommand`], [`SampleBatch`] and [`ReadingBatch`] have room for
//! [`crate::msg::MAX_VEHICLES`] = 1024 vehicles (a command is ~150 KB), but a tick of N
//! vehicles uses N entries. `send_copy` would copy the whole capacity twice per message
//! (onto the stack as an argument, then into shared memory) whatever N: at N = 16 that is
//! ~300 KB of copying per command. [`WritePrefix::write_prefix`] writes the header, the
//! scalars and the first `n` entries of each array straight into the loaned chunk; the rest
//! of the chunk keeps whatever bytes it held (zeros from the kernel, or an older message of
//! the same type), which no reader looks at: every reader goes through the counts
//! (`n_vehicles`, `n_leaders`, `n_plan`, `n`), as `is_valid` and the accessors do.
//!
//! Every field of these payloads is a plain integer or `f64` (any bit pattern is a value),
//! so the chunk is a valid payload whatever its stale bytes.

#![allow(unsafe_code)] // raw-pointer writes into loaned chunks; each block says why it is sound

use std::fmt::Debug;
use std::mem::MaybeUninit;
use std::ptr::addr_of_mut;

use iceoryx2::active_request::ActiveRequest;
use iceoryx2::pending_response::PendingResponse;
use iceoryx2::port::client::Client;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::{ipc, ZeroCopySend};

use crate::msg::coordinator_to_agent::BodyCommand;
use crate::msg::coordinator_to_field::SampleBatch;
use crate::msg::field_to_coordinator::ReadingBatch;
use crate::msg::{MAX_LEADERS, MAX_NEAR_ENTRIES, MAX_VEHICLES};
use crate::topics::TopicError;
use vbap_math::schedule::MAX_PLAN;

/// A fixed-capacity payload that can be written into shared memory entries-in-use only.
pub trait WritePrefix: Sized {
    /// Writes `self`'s header, scalars and entries in use into `dst`.
    ///
    /// After it returns, every field a reader of `dst` looks at (the counts, and the
    /// entries they cover) equals `self`'s. The tail beyond the counts is left as it was.
    fn write_prefix(&self, dst: &mut MaybeUninit<Self>);
}

fn err(what: &str, e: impl Debug) -> TopicError {
    TopicError::Service {
        service: what.to_string(),
        reason: format!("{e:?}"),
    }
}

/// Publishes `value` through `publisher`, its entries in use only (see the module).
pub fn publish<T: WritePrefix + Debug + ZeroCopySend>(
    publisher: &Publisher<ipc::Service, T, ()>,
    value: &T,
) -> Result<(), TopicError> {
    let mut sample = publisher
        .loan_uninit()
        .map_err(|e| err("loaning a sample", e))?;
    value.write_prefix(sample.payload_mut());
    // SAFETY: every field a reader uses is written (`WritePrefix`); the rest of the chunk
    // holds plain integers and floats of an older message of the type, or zeros.
    let sample = unsafe { sample.assume_init() };
    sample.send().map(|_| ()).map_err(|e| err("publishing", e))
}

/// Sends request `value` through `client`, its entries in use only (see the module).
pub fn request<Q, R>(
    client: &Client<ipc::Service, Q, (), R, ()>,
    value: &Q,
) -> Result<PendingResponse<ipc::Service, Q, (), R, ()>, TopicError>
where
    Q: WritePrefix + Debug + ZeroCopySend,
    R: Debug + ZeroCopySend,
{
    let mut request = client
        .loan_uninit()
        .map_err(|e| err("loaning a request", e))?;
    value.write_prefix(request.payload_mut());
    // SAFETY: as in [`publish`].
    let request = unsafe { request.assume_init() };
    request.send().map_err(|e| err("sending a request", e))
}

/// Answers `active` with `value`, its entries in use only (see the module).
pub fn respond<Q, R>(
    active: &ActiveRequest<ipc::Service, Q, (), R, ()>,
    value: &R,
) -> Result<(), TopicError>
where
    Q: Debug + ZeroCopySend,
    R: WritePrefix + Debug + ZeroCopySend,
{
    let mut response = active
        .loan_uninit()
        .map_err(|e| err("loaning a response", e))?;
    value.write_prefix(response.payload_mut());
    // SAFETY: as in [`publish`].
    let response = unsafe { response.assume_init() };
    response.send().map_err(|e| err("sending a response", e))
}

/// Copies `n` elements of `src` to the array field at `dst` (a pointer to `[T; CAP]`).
///
/// # Safety
/// `dst` points to writable memory of a `[T; CAP]`, and `n ≤ CAP`, `n ≤ src.len()`.
unsafe fn copy_prefix<T: Copy, const CAP: usize>(dst: *mut [T; CAP], src: &[T], n: usize) {
    debug_assert!(n <= CAP && n <= src.len());
    // SAFETY: by the caller; `src` is a shared slice, `dst` is a distinct chunk.
    unsafe { std::ptr::copy_nonoverlapping(src.as_ptr(), dst.cast::<T>(), n) }
}

impl WritePrefix for BodyCommand {
    fn write_prefix(&self, dst: &mut MaybeUninit<Self>) {
        let d = dst.as_mut_ptr();
        let n_l = (self.n_leaders as usize).min(MAX_LEADERS);
        let n_v = (self.n_vehicles as usize).min(MAX_VEHICLES);
        let n_p = (self.n_plan as usize).min(MAX_PLAN);
        let n_near = (self.n_near as usize).min(MAX_NEAR_ENTRIES);
        // SAFETY: `d` is valid for writes of a whole `BodyCommand` (a `MaybeUninit` of it);
        // only fields are written, through raw pointers (no reference to the uninitialised
        // value is formed), and each array prefix is within its capacity.
        unsafe {
            addr_of_mut!((*d).header).write(self.header);
            addr_of_mut!((*d).s).write(self.s);
            addr_of_mut!((*d).sdot).write(self.sdot);
            addr_of_mut!((*d).r).write(self.r);
            addr_of_mut!((*d).scale).write(self.scale);
            addr_of_mut!((*d).inter).write(self.inter);
            addr_of_mut!((*d).leader).write(self.leader);
            addr_of_mut!((*d).damping).write(self.damping);
            addr_of_mut!((*d).velocity).write(self.velocity);
            addr_of_mut!((*d).n_leaders).write(n_l as u32);
            addr_of_mut!((*d).n_vehicles).write(n_v as u32);
            copy_prefix(addr_of_mut!((*d).leaders), &self.leaders, n_l);
            copy_prefix(addr_of_mut!((*d).snapshot), &self.snapshot, n_v);
            addr_of_mut!((*d).plan_start).write(self.plan_start);
            addr_of_mut!((*d).plan_ticks).write(self.plan_ticks);
            addr_of_mut!((*d).n_plan).write(n_p as u32);
            addr_of_mut!((*d)._plan_pad).write(0);
            copy_prefix(addr_of_mut!((*d).plan), &self.plan, n_p);
            addr_of_mut!((*d).n_near).write(n_near as u32);
            copy_prefix(addr_of_mut!((*d).near_start), &self.near_start, n_v + 1);
            copy_prefix(addr_of_mut!((*d).near), &self.near, n_near);
        }
    }
}

impl WritePrefix for SampleBatch {
    fn write_prefix(&self, dst: &mut MaybeUninit<Self>) {
        let d = dst.as_mut_ptr();
        let n = (self.n as usize).min(MAX_VEHICLES);
        // SAFETY: as for `BodyCommand`.
        unsafe {
            addr_of_mut!((*d).header).write(self.header);
            addr_of_mut!((*d).n).write(n as u32);
            addr_of_mut!((*d)._pad).write(0);
            copy_prefix(addr_of_mut!((*d).reads), &self.reads, n);
        }
    }
}

impl WritePrefix for ReadingBatch {
    fn write_prefix(&self, dst: &mut MaybeUninit<Self>) {
        let d = dst.as_mut_ptr();
        let n = (self.n as usize).min(MAX_VEHICLES);
        // SAFETY: as for `BodyCommand`.
        unsafe {
            addr_of_mut!((*d).header).write(self.header);
            addr_of_mut!((*d).request_seq).write(self.request_seq);
            addr_of_mut!((*d).n).write(n as u32);
            addr_of_mut!((*d)._pad).write(0);
            copy_prefix(addr_of_mut!((*d).readings), &self.readings, n);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::coordinator_to_agent::SnapshotEntry;
    use crate::msg::coordinator_to_field::SensorRead;
    use crate::msg::field_to_coordinator::Reading;
    use crate::msg::Header;

    /// A chunk full of an older, larger message: what a reader sees of the new one through
    /// the counts equals the new one exactly.
    #[test]
    fn a_prefix_write_over_an_older_message_reads_back_exactly() {
        let mut old = Box::new(BodyCommand::empty());
        old.n_vehicles = 40;
        old.n_leaders = 3;
        for (i, e) in old.snapshot.iter_mut().take(40).enumerate() {
            e.id = 1000 + i as u32;
            e.position = [9.0; 3];
        }
        old.n_near = 50;
        old.near[..50].fill(7);
        old.near_start[..41].fill(50);
        let mut new = Box::new(BodyCommand::empty());
        new.header = Header::new(Header::COORDINATOR, 7, 0.35, 8);
        new.s = 1.5;
        new.scale = 0.9;
        new.n_leaders = 1;
        new.leaders[0] = [1.0, 2.0, 0.0];
        new.n_vehicles = 3;
        for i in 0..3 {
            new.snapshot[i] = SnapshotEntry {
                id: i as u32,
                alive: SnapshotEntry::MEMBER,
                position: [i as f64, -(i as f64), 0.5],
                ..SnapshotEntry::default()
            };
        }
        new.n_near = 4;
        new.near[..4].copy_from_slice(&[1, 2, 0, 0]);
        new.near_start[..4].copy_from_slice(&[0, 2, 3, 4]);
        let mut chunk: Box<MaybeUninit<BodyCommand>> = Box::new(MaybeUninit::new(*old));
        new.write_prefix(&mut chunk);
        // SAFETY: the chunk held a whole command before the prefix write.
        let got = unsafe { chunk.assume_init_ref() };
        assert!(got.is_valid());
        assert_eq!(got.header, new.header);
        assert_eq!((got.s, got.scale), (new.s, new.scale));
        assert_eq!(got.leader_positions(), new.leader_positions());
        assert_eq!(got.snapshot_entries(), new.snapshot_entries());
        assert_eq!(got.schedule().is_none(), new.schedule().is_none());
        for i in 0..4 {
            assert_eq!(got.near_of(i), new.near_of(i), "list {i}");
        }
        assert_eq!(got.near_of(0), &[1, 2]);
        // The tail keeps the old bytes: only the counts make it invisible.
        assert_eq!(got.snapshot[3].id, 1003);
    }

    #[test]
    fn batches_write_their_entries_in_use() {
        let mut reads = Box::new(SampleBatch::empty());
        reads.n = 2;
        reads.reads[1] = SensorRead {
            vehicle: 5,
            tick: 3,
            t: 0.3,
            ..SensorRead::default()
        };
        let mut chunk: Box<MaybeUninit<SampleBatch>> = Box::new(MaybeUninit::zeroed());
        reads.write_prefix(&mut chunk);
        // SAFETY: zeroed, then written: every field is plain data.
        assert_eq!(unsafe { chunk.assume_init_ref() }.reads(), reads.reads());

        let mut readings = Box::new(ReadingBatch::empty());
        readings.n = 1;
        readings.request_seq = 9;
        readings.readings[0] = Reading {
            vehicle: 5,
            rejected: 0,
            tick: 3,
            value: 2.5,
        };
        let mut chunk: Box<MaybeUninit<ReadingBatch>> = Box::new(MaybeUninit::zeroed());
        readings.write_prefix(&mut chunk);
        // SAFETY: as above.
        let got = unsafe { chunk.assume_init_ref() };
        assert_eq!((got.request_seq, got.readings()), (9, readings.readings()));
    }
}
