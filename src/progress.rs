//! Progress reporting: a bar on a terminal, one plain line per item otherwise (logs, CI).

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};

/// Reports progress over `total` items.
pub struct Progress {
    bar: Option<ProgressBar>,
    label: String,
    total: u64,
    /// Off a terminal: units done, and the next tenth of the total to report.
    done: AtomicU64,
    next_tenth: AtomicU64,
}

impl Progress {
    /// A bar when standard error is a terminal, plain lines otherwise.
    pub fn new(label: &str, total: usize) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(total as u64);
            bar.set_style(
                ProgressStyle::with_template("{prefix} [{bar:40}] {pos}/{len} {msg} ({eta})")
                    .expect("static template")
                    .progress_chars("=> "),
            );
            bar.set_prefix(label.to_owned());
            bar
        });
        Self {
            bar,
            label: label.to_owned(),
            total: total as u64,
            done: AtomicU64::new(0),
            next_tenth: AtomicU64::new(1),
        }
    }

    /// One item is done; `what` names it.
    pub fn done(&self, what: &str) {
        match &self.bar {
            Some(bar) => {
                bar.set_message(what.to_owned());
                bar.inc(1);
            }
            None => eprintln!("{}: {what}", self.label),
        }
    }

    /// `n` more units of work are done (fine-grained work such as samples): off a terminal, a
    /// line at each tenth of the total, for farm logs.
    pub fn advance(&self, n: u64) {
        if let Some(bar) = &self.bar {
            bar.inc(n);
            return;
        }
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        let tenths = (done.saturating_mul(10) / self.total.max(1)).min(10);
        let next = self.next_tenth.load(Ordering::Relaxed);
        if tenths >= next
            && self
                .next_tenth
                .compare_exchange(next, tenths + 1, Ordering::Relaxed, Ordering::Relaxed)
                .is_ok()
        {
            eprintln!("{}: {}%", self.label, tenths * 10);
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
