//! A slab: values in one vector, each at a slot that stays its own until freed, freed slots
//! reused before the vector grows. The stores that link their entries by index (the touching
//! pairs' lists, the parked searches' keys) keep their values here, so removing an entry never
//! moves another and memory stays at the most entries held at once.
//!
//! It owns the slots only: it never knows what links to them, and a freed slot keeps its value
//! until reused (its owner must not read it).

use std::ops::{Index, IndexMut};

/// Values at stable slots (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct Slab<T> {
    values: Vec<T>,
    /// Slots freed, to be reused first.
    free: Vec<u32>,
}

impl<T> Default for Slab<T> {
    fn default() -> Self {
        Slab { values: Vec::new(), free: Vec::new() }
    }
}

impl<T> Slab<T> {
    /// Stores `value` in a freed slot, or a new one, and returns the slot.
    pub(crate) fn insert(&mut self, value: T) -> u32 {
        match self.free.pop() {
            Some(slot) => {
                self.values[slot as usize] = value;
                slot
            }
            None => {
                self.values.push(value);
                (self.values.len() - 1) as u32
            }
        }
    }

    /// Frees `slot` for reuse.
    pub(crate) fn free(&mut self, slot: u32) {
        self.free.push(slot);
    }

    /// Slots ever taken: the most values held at once.
    #[cfg(test)]
    pub(crate) fn slots(&self) -> usize {
        self.values.len()
    }

    /// Values held now.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.values.len() - self.free.len()
    }

    /// Bytes held (capacity).
    pub(crate) fn memory_bytes(&self) -> usize {
        self.values.capacity() * std::mem::size_of::<T>() + self.free.capacity() * std::mem::size_of::<u32>()
    }
}

impl<T> Index<u32> for Slab<T> {
    type Output = T;
    #[inline]
    fn index(&self, slot: u32) -> &T {
        &self.values[slot as usize]
    }
}

impl<T> IndexMut<u32> for Slab<T> {
    #[inline]
    fn index_mut(&mut self, slot: u32) -> &mut T {
        &mut self.values[slot as usize]
    }
}
