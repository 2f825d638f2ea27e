//! The refinement thread: each new object's network field refined toward the skinning
//! eigenmodes (`inference.refine`), apart from the build thread, so that new geometry never
//! waits for a refinement, and at the lowest priority with a pool of its own, so that it takes
//! neither the build's nor the stepping thread's CPU.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::Arc;
use std::time::Duration;

use super::object_key::ObjectKey;
use super::outputs::SharedOutputs;
use crate::msg::Status;
use crate::pipeline::{BasisPlan, PreparedBasis};
use crate::skinning::{RefineBudget, RefineOptions};

/// A running object's field refined toward the skinning eigenmodes (`inference.refine`).
pub struct RefinedField {
    /// The object's id.
    pub id: u32,
    /// Which object it is.
    pub key: ObjectKey,
    /// The field sampled where the body needs it.
    pub prepared: PreparedBasis,
}

/// One object's refinement, asked for once its body went to the stepper.
pub struct RefineJob {
    /// The object's id.
    pub id: u32,
    /// Which object it is.
    pub key: ObjectKey,
    /// What the refinement needs of its body.
    pub plan: BasisPlan,
    /// How long it may take.
    pub budget: RefineBudget,
}

/// Runs until `jobs` closes: refines the newest job per object (an object rebuilt meanwhile
/// needs only its latest field) and hands each result to `deliver`, which says whether the
/// stepper still listens. Builds come first: while `building` is set a refinement does not
/// start, and one under way stops after its current iteration, keeping what it has (a span
/// at least as good as the network's).
pub fn run_refiner(
    jobs: Receiver<RefineJob>,
    mut deliver: impl FnMut(RefinedField) -> bool,
    outputs: SharedOutputs,
    building: Arc<AtomicBool>,
) {
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .thread_name(|_| "physskin-refine".into())
        .start_handler(|_| lowest_priority())
        .build()
    {
        Ok(pool) => pool,
        Err(e) => {
            let message = format!("no refinement thread: {e}");
            outputs.report(Status::WARN, 0, "refine_failed", message);
            return;
        }
    };
    while let Ok(first) = jobs.recv() {
        let mut newest = vec![first];
        for job in jobs.try_iter() {
            match newest.iter().position(|j| j.key == job.key) {
                Some(i) => newest[i] = job,
                None => newest.push(job),
            }
        }
        for job in newest {
            let options = RefineOptions {
                budget: job.budget,
                ..Default::default()
            };
            while building.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(2));
            }
            let stop = || building.load(Ordering::Relaxed);
            match pool.install(|| job.plan.refined_until(&options, &stop)) {
                Ok(prepared) => {
                    let (id, key) = (job.id, job.key);
                    if !deliver(RefinedField { id, key, prepared }) {
                        return;
                    }
                }
                Err(e) => {
                    let message = format!("{}: the field was not refined: {e}", job.key);
                    outputs.report(Status::WARN, job.id, "refine_failed", message);
                }
            }
        }
    }
}

/// SCHED_IDLE for the calling thread: it runs only when nothing else wants the CPU, and any
/// other thread that wakes (the step thread on its tick) takes the CPU from it at once, where
/// a nice thread would keep it for the scheduler's granularity (milliseconds).
fn lowest_priority() {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: sched_setscheduler on this thread's own id, with a valid parameter block, has
    // no memory effects; a failure only leaves the policy as it was.
    unsafe {
        libc::sched_setscheduler(libc::gettid(), libc::SCHED_IDLE, &param);
    }
}
