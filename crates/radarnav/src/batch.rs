//! Batches of independent runs on all cores, longest first.
//!
//! A batch's wall time is its CPU time over the cores plus whatever one core still runs
//! after the others ran out of work. Split in halves (rayon's `par_iter`), a batch whose
//! long runs sit together leaves one core on them while the other idles; taken one by one
//! from a queue in order of their expected cost, longest first (Graham's LPT rule), the
//! tail is at most one of the shortest runs.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// `f` of every job, on all of rayon's threads, the jobs started in decreasing order of
/// `cost` (ties in their order); the results in the jobs' order. `f` runs once per job.
pub fn map_longest_first<J, R, C, F>(jobs: &[J], cost: C, f: F) -> Vec<R>
where
    J: Sync,
    R: Send,
    C: Fn(&J) -> f64,
    F: Fn(&J) -> R + Sync,
{
    let mut order: Vec<usize> = (0..jobs.len()).collect();
    let costs: Vec<f64> = jobs.iter().map(&cost).collect();
    order.sort_by(|&a, &b| costs[b].total_cmp(&costs[a]));
    let next = AtomicUsize::new(0);
    let results: Vec<Mutex<Option<R>>> = jobs.iter().map(|_| Mutex::new(None)).collect();
    let workers = rayon::current_num_threads().min(jobs.len());
    rayon::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|_| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&i) = order.get(k) else {
                        break;
                    };
                    let r = f(&jobs[i]);
                    // A poisoned slot only means another job panicked; that panic is
                    // what the scope reports.
                    *results[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
                }
            });
        }
    });
    results
        .into_iter()
        .map(|m| {
            m.into_inner()
                .unwrap_or_else(|e| e.into_inner())
                .expect("every job ran")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_back_in_the_jobs_order_and_long_jobs_start_first() {
        let jobs: Vec<u64> = (0..50).map(|k| (k * 37) % 11).collect();
        let started = Mutex::new(Vec::new());
        let out = map_longest_first(
            &jobs,
            |&j| j as f64,
            |&j| {
                started.lock().expect("lock").push(j);
                j * 2
            },
        );
        assert_eq!(out, jobs.iter().map(|j| j * 2).collect::<Vec<_>>());
        // Taken from the queue in decreasing cost: with any number of threads, the first
        // job started is a longest one, and the last ones are short.
        let started = started.into_inner().expect("lock");
        assert_eq!(started.len(), jobs.len());
        assert_eq!(started[0], 10);
        assert!(started[started.len() - 1] <= 1);
        assert!(map_longest_first(&[] as &[u64], |_| 0.0, |&j| j).is_empty());
    }
}
