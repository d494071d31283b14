//! The hand-over of a slow-rate redesign: the control loop never waits for it.
//!
//! ```text
//! sample k        the controller asks for a redesign → the job is posted, due at k + L
//! background      take_job() → Controller::redesign(job) → deliver(ticket, design)
//! sample k + L    before the step: delivered → adopted;  not delivered → dropped, HANDOVER_MISSED
//! ```
//! The job is applied at exactly sample k + L whatever the background's timing, so a host run and
//! a target run of the same inputs are bit-identical as long as every redesign finishes within L
//! sample periods; one that does not leaves the old gains in place and is flagged, never waited
//! for. While a job is in flight no other is posted (the controller's request stays pending and
//! is taken after the hand-over).
//!
//! The state is a double buffer in the plain sense: the job slot (written by the loop, read by the
//! background) and the result slot (written by the background, read by the loop), each owned by
//! one side at a time. On a target the two slots cross the interrupt boundary through whatever
//! the firmware uses for that (a critical section around a copy); the loop itself only touches
//! its own [`Handover`].

/// Identifies one posted job: the sample it is due at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ticket {
    /// The sample index k + L at which the result is adopted.
    pub due: u32,
}

/// A job handed to the background, with its ticket.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Posted<J> {
    /// Where the result goes back.
    pub ticket: Ticket,
    /// The job.
    pub job: J,
}

/// What the hand-over did this sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HandoverEvent<D> {
    /// Nothing due.
    Idle,
    /// The result due now was delivered: adopt it.
    Adopt(D),
    /// The result due now was not delivered: the old values stay.
    Missed,
}

/// One redesign in flight at most, adopted at the sample its ticket names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Handover<J, D> {
    /// The job in flight (posted, not yet due).
    in_flight: Option<Ticket>,
    /// The job, until the background takes it.
    job: Option<Posted<J>>,
    /// The background's result for the job in flight.
    result: Option<D>,
}

impl<J: Copy, D: Copy> Default for Handover<J, D> {
    fn default() -> Self {
        Self::new()
    }
}

impl<J: Copy, D: Copy> Handover<J, D> {
    /// Nothing in flight.
    pub const fn new() -> Self {
        Self {
            in_flight: None,
            job: None,
            result: None,
        }
    }

    /// True when a job may be posted (none in flight).
    pub fn is_free(&self) -> bool {
        self.in_flight.is_none()
    }

    /// Posts `job`, due at sample `due`. Ignored (false) while another job is in flight.
    pub fn post(&mut self, job: J, due: u32) -> bool {
        if self.in_flight.is_some() {
            return false;
        }
        let ticket = Ticket { due };
        self.in_flight = Some(ticket);
        self.job = Some(Posted { ticket, job });
        self.result = None;
        true
    }

    /// The background's side: the posted job, once.
    pub fn take_job(&mut self) -> Option<Posted<J>> {
        self.job.take()
    }

    /// The background's side: the posted job, once, if `f` takes it (`Some`: what the taker
    /// wants of it); otherwise it stays posted for another taker.
    pub fn take_job_if<T>(&mut self, f: impl FnOnce(&J) -> Option<T>) -> Option<Posted<T>> {
        let posted = self.job.as_ref()?;
        let job = f(&posted.job)?;
        let ticket = posted.ticket;
        self.job = None;
        Some(Posted { ticket, job })
    }

    /// The background's side: the result for `ticket`. A result for a job no longer in flight
    /// (it was due and missed) is dropped (false).
    pub fn deliver(&mut self, ticket: Ticket, design: D) -> bool {
        if self.in_flight != Some(ticket) {
            return false;
        }
        self.result = Some(design);
        true
    }

    /// The loop's side, before the step of sample `k`: the result due now, if any — lent from
    /// its slot, not copied out (on a target the loop adopts it from there, with no copy of a
    /// design on the interrupt's stack). It stays in the slot until the next [`Self::post`] and
    /// is adopted once: nothing is in flight any more, so a later sample is [`HandoverEvent::Idle`]
    /// and a late [`Self::deliver`] is refused.
    pub fn due(&mut self, k: u32) -> HandoverEvent<&D> {
        match self.in_flight {
            Some(t) if t.due == k => {
                self.in_flight = None;
                self.job = None;
                match &self.result {
                    Some(d) => HandoverEvent::Adopt(d),
                    None => HandoverEvent::Missed,
                }
            }
            _ => HandoverEvent::Idle,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adopts_at_the_due_sample_only_and_flags_a_miss() {
        let mut h = Handover::<u8, u16>::new();
        assert!(h.post(7, 10));
        assert!(!h.post(8, 11), "one job in flight");
        let posted = h.take_job().unwrap();
        assert_eq!(posted.job, 7);
        assert_eq!(h.take_job(), None, "taken once");
        assert!(h.deliver(posted.ticket, 70));
        assert_eq!(h.due(9), HandoverEvent::Idle, "not before k + L");
        assert_eq!(h.due(10), HandoverEvent::Adopt(&70));
        assert_eq!(h.due(10), HandoverEvent::Idle, "adopted once");
        // A miss: nothing delivered by the due sample; a late delivery is refused.
        assert!(h.post(9, 20));
        let late = h.take_job().unwrap();
        assert_eq!(h.due(20), HandoverEvent::Missed);
        assert!(!h.deliver(late.ticket, 90));
        assert!(h.is_free());
        assert_eq!(h.due(21), HandoverEvent::Idle);
    }

    /// A job is taken only by the taker it is for, and then once; another taker leaves it posted.
    #[test]
    fn a_job_is_taken_only_by_its_taker() {
        let mut h = Handover::<u8, u16>::new();
        assert!(h.post(7, 10));
        assert_eq!(h.take_job_if(|&j| (j == 8).then_some(())), None);
        let posted = h.take_job_if(|&j| (j == 7).then_some(j * 2)).unwrap();
        assert_eq!((posted.ticket.due, posted.job), (10, 14));
        assert_eq!(h.take_job_if(|&j| Some(j)), None, "taken once");
    }
}
