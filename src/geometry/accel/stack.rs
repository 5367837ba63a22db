//! The traversal stack: fixed-size on the call stack, spilling to the heap only for
//! pathologically deep trees, so no ray allocates and no tree depth can overflow it.

use std::mem::MaybeUninit;

/// A traversal stack entry: node index and the ray distance at which its box is entered.
#[derive(Clone, Copy)]
pub(super) struct Entry {
    /// Index into the node array.
    pub node: u32,
    /// Entry distance of the node's box along the ray (world units).
    pub t: f32,
}

/// Fixed-size traversal stack of entries `E` (an [`Entry`] for one ray, a node with sixteen
/// lanes' distances for a packet) that spills to the heap only for pathologically deep trees,
/// so the common case never allocates and no tree depth can overflow it. The buffer is left
/// uninitialised (zeroing it cost a memset per ray). 64 entries: an 8-wide node pushes up to
/// seven children per level.
pub(super) struct Stack<E = Entry> {
    buf: [MaybeUninit<E>; 64],
    len: usize,
    spill: Vec<E>,
}

impl<E: Copy> Stack<E> {
    /// An empty stack (no allocation).
    #[inline(always)]
    pub fn new() -> Stack<E> {
        Stack {
            buf: [const { MaybeUninit::uninit() }; 64],
            len: 0,
            spill: Vec::new(),
        }
    }

    /// Pushes `e`, onto the heap spill once the fixed buffer is full.
    #[inline(always)]
    pub fn push(&mut self, e: E) {
        if self.len < self.buf.len() {
            self.buf[self.len].write(e);
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }

    /// The most recently pushed entry, if any.
    #[inline(always)]
    pub fn pop(&mut self) -> Option<E> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: slots below `len` were written by `push` (len only grows there) and E is
        // Copy, so reading one leaves nothing to drop twice.
        Some(unsafe { self.buf[self.len].assume_init_read() })
    }
}
