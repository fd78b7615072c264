//! The messages between ranks, through MPI (rsmpi over the system's MPI library): runs of 64-bit
//! words to other ranks, reductions of the frame's figures, and the contacts gathered at rank 0.
//! It counts the bytes each rank sends, which the summary reports.
//!
//! It owns the MPI calls and nothing else: it never reads what the words mean.

use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::request::WaitGuard;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::{Count, Rank};

pub struct Comm {
    world: SimpleCommunicator,
    pub rank: usize,
    pub size: usize,
    /// Bytes this rank sent to others since the last [`Comm::take_bytes_sent`].
    bytes_sent: u64,
}

/// Displacements of consecutive blocks of `counts` words.
fn displacements(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |start, &count| {
            let here = *start;
            *start += count;
            Some(here)
        })
        .collect()
}

fn count(words: usize) -> Count {
    Count::try_from(words).expect("a message of fewer than 2^31 words (16 GiB)")
}

impl Comm {
    pub fn new(world: SimpleCommunicator) -> Comm {
        let (rank, size) = (world.rank() as usize, world.size() as usize);
        Comm { world, rank, size, bytes_sent: 0 }
    }

    /// Sends `outgoing[k]` to each rank k of `near` and returns what each of them sent here, in
    /// the order of `near`. Neighbours only, point to point: a rank's messages per frame do not
    /// grow with the number of ranks. `near` must be symmetric (each of them lists this rank).
    pub fn exchange(&mut self, near: &[usize], outgoing: &[Vec<u64>]) -> Vec<u64> {
        let mut incoming = Vec::new();
        mpi::request::scope(|scope| {
            let mut sending = Vec::with_capacity(near.len());
            for &rank in near {
                let words = &outgoing[rank][..];
                self.bytes_sent += 8 * words.len() as u64;
                sending.push(WaitGuard::from(self.world.process_at_rank(rank as Rank).immediate_send(scope, words)));
            }
            for &rank in near {
                let (words, _) = self.world.process_at_rank(rank as Rank).receive_vec::<u64>();
                incoming.extend_from_slice(&words);
            }
        });
        incoming
    }

    /// The largest of every rank's `values`, element by element.
    pub fn max<T: Equivalence + Copy + Default>(&self, values: &[T]) -> Vec<T> {
        let mut out = vec![T::default(); values.len()];
        self.world.all_reduce_into(values, &mut out[..], SystemOperation::max());
        out
    }

    /// The sum of every rank's `values`, element by element.
    pub fn sum<T: Equivalence + Copy + Default>(&self, values: &[T]) -> Vec<T> {
        let mut out = vec![T::default(); values.len()];
        self.world.all_reduce_into(values, &mut out[..], SystemOperation::sum());
        out
    }

    /// Every rank's `words`, at rank 0 (in rank order; `None` on the other ranks).
    pub fn gather(&mut self, words: &[u64]) -> Option<Vec<Vec<u64>>> {
        let root = self.world.process_at_rank(0);
        let mine = count(words.len());
        if self.rank != 0 {
            self.bytes_sent += 8 * words.len() as u64;
            root.gather_into(&mine);
            root.gather_varcount_into(words);
            return None;
        }
        let mut counts = vec![0 as Count; self.size];
        root.gather_into_root(&mine, &mut counts[..]);
        let at = displacements(&counts);
        let mut all = vec![0u64; counts.iter().map(|&c| c as usize).sum()];
        root.gather_varcount_into_root(words, &mut PartitionMut::new(&mut all[..], &counts[..], &at[..]));
        Some(at.iter().zip(&counts).map(|(&start, &n)| all[start as usize..(start + n) as usize].to_vec()).collect())
    }

    /// The bytes sent since the last call.
    pub fn take_bytes_sent(&mut self) -> u64 {
        std::mem::take(&mut self.bytes_sent)
    }

    /// Ends every rank of the run at once with exit code `code`: one rank's error must not leave
    /// the others waiting for it.
    pub fn abort(&self, code: i32) -> ! {
        self.world.abort(code)
    }
}
