//! A sink's counters, shared with the runtime's health report, and their snapshots.

use serde::Serialize;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};

/// One TCP client's view.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct ClientStats {
    pub peer: String,
    /// Samples written to this client's socket.
    pub samples_sent: u64,
    /// Samples this client missed because its queue was full (it fell behind).
    pub samples_dropped: u64,
    pub connected: bool,
}

/// Live counters of one TCP client (updated by the server and the client's writer task).
#[derive(Debug, Default)]
pub struct ClientCounters {
    pub peer: String,
    pub sent: AtomicU64,
    pub dropped: AtomicU64,
    /// Set while the client is behind (its queue full), to log the start of a lag once.
    pub(super) lagging: AtomicBool,
}

impl ClientCounters {
    pub(super) fn snapshot(&self) -> ClientStats {
        ClientStats {
            peer: self.peer.clone(),
            samples_sent: self.sent.load(Relaxed),
            samples_dropped: self.dropped.load(Relaxed),
            connected: true,
        }
    }
}

/// The TCP clients that have left, folded together (their per-client entries are freed).
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct GoneClients {
    pub clients: u64,
    pub samples_sent: u64,
    pub samples_dropped: u64,
}

/// Counters of one sink, shared with the runtime's health report.
#[derive(Debug, Default)]
pub struct SinkStats {
    /// Samples handed to the consumer (written to stdout/file, datagrams sent, or queued to
    /// the TCP clients; each client's own count is what was written to it).
    pub samples_out: AtomicU64,
    /// Samples this sink (as a whole) missed because its queue was full.
    pub dropped: AtomicU64,
    /// Health reports written.
    pub health_out: AtomicU64,
    /// Write/send errors.
    pub errors: AtomicU64,
    /// Inline sinks: pass-through messages (not IMU data) dropped with a side batch while stuck.
    pub messages_dropped: AtomicU64,
    /// Zenoh sinks: messages Zenoh's own congestion control dropped (a subscriber or router
    /// behind), as Zenoh counts them for the session.
    pub congestion_dropped: AtomicU64,
    /// Zenoh sinks: samples published while no subscriber matched the key (none yet, or the
    /// router or every subscriber gone): sent to nobody, not counted as dropped.
    pub no_subscriber: AtomicU64,
    /// TCP clients connected now.
    pub clients: Mutex<Vec<Arc<ClientCounters>>>,
    /// TCP clients that have left.
    pub gone: Mutex<GoneClients>,
}

/// Snapshot of a sink for reports.
#[derive(Debug, Clone, Serialize)]
pub struct SinkReport {
    pub name: String,
    pub samples_out: u64,
    pub dropped: u64,
    pub health_out: u64,
    pub errors: u64,
    /// Inline sinks: pass-through messages dropped while stuck.
    pub messages_dropped: u64,
    /// Zenoh sinks: messages Zenoh's congestion control dropped (in `dropped_total`).
    #[serde(skip_serializing_if = "is_zero")]
    pub congestion_dropped: u64,
    /// Zenoh sinks: samples published while no subscriber matched (not in `dropped_total`).
    #[serde(skip_serializing_if = "is_zero")]
    pub no_subscriber: u64,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub clients: Vec<ClientStats>,
    #[serde(skip_serializing_if = "is_zero_gone")]
    pub clients_gone: GoneClients,
}

fn is_zero_gone(g: &GoneClients) -> bool {
    g.clients == 0
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

impl SinkReport {
    /// Samples this sink lost, including every client's lag (present and gone) and what
    /// Zenoh's congestion control dropped.
    pub fn dropped_total(&self) -> u64 {
        self.dropped
            + self.congestion_dropped
            + self.clients.iter().map(|c| c.samples_dropped).sum::<u64>()
            + self.clients_gone.samples_dropped
    }
}

impl SinkStats {
    pub fn report(&self, name: &str) -> SinkReport {
        SinkReport {
            name: name.to_string(),
            samples_out: self.samples_out.load(Relaxed),
            dropped: self.dropped.load(Relaxed),
            health_out: self.health_out.load(Relaxed),
            errors: self.errors.load(Relaxed),
            messages_dropped: self.messages_dropped.load(Relaxed),
            congestion_dropped: self.congestion_dropped.load(Relaxed),
            no_subscriber: self.no_subscriber.load(Relaxed),
            clients: self
                .clients
                .lock()
                .map(|c| c.iter().map(|k| k.snapshot()).collect())
                .unwrap_or_default(),
            clients_gone: self.gone.lock().map(|g| *g).unwrap_or_default(),
        }
    }

    /// A client has left: free its entry, keep its counts in the totals.
    pub(super) fn client_left(&self, c: &Arc<ClientCounters>) {
        if let Ok(mut live) = self.clients.lock() {
            let before = live.len();
            live.retain(|k| !Arc::ptr_eq(k, c));
            if live.len() < before
                && let Ok(mut g) = self.gone.lock()
            {
                g.clients += 1;
                g.samples_sent += c.sent.load(Relaxed);
                g.samples_dropped += c.dropped.load(Relaxed);
            }
        }
    }
}
