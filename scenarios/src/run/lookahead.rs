//! The inputs a source has read ahead of the estimator, in time order: some ready, some still
//! with the front end's [stage](super::stage). A source with a front end reads until the
//! capture after the next input's is with the stage, so that the front end tracks it while
//! the estimator takes what comes before; one without reads one input at a time.

use std::collections::VecDeque;

use super::driver::Input;

/// One input read ahead.
pub(crate) enum Slot<W> {
    /// Ready for the estimator.
    Ready(Input),
    /// A capture with the front end's stage; `W`: what the source keeps of it meanwhile.
    Tracking(W),
}

/// The inputs read ahead and whether the source has more.
pub(crate) struct Lookahead<W> {
    slots: VecDeque<Slot<W>>,
    ended: bool,
}

impl<W> Default for Lookahead<W> {
    fn default() -> Self {
        Self {
            slots: VecDeque::new(),
            ended: false,
        }
    }
}

impl<W> Lookahead<W> {
    /// Whether the source should read another input first: with a front end (`tracking`), until
    /// a capture follows the next input; without, until one input is read; never past the end.
    pub(crate) fn wants_more(&self, tracking: bool) -> bool {
        if self.ended {
            return false;
        }
        if tracking {
            let mut later = self.slots.iter().skip(1);
            !later.any(|s| matches!(s, Slot::Tracking(_)))
        } else {
            self.slots.is_empty()
        }
    }

    /// Adds an input read.
    pub(crate) fn push(&mut self, slot: Slot<W>) {
        self.slots.push_back(slot);
    }

    /// The source has no more inputs.
    pub(crate) fn end(&mut self) {
        self.ended = true;
    }

    /// The next input for the estimator.
    pub(crate) fn pop(&mut self) -> Option<Slot<W>> {
        self.slots.pop_front()
    }
}
