//! The one Zenoh session of a run (`[zenoh]`), shared by a Zenoh source and every Zenoh sink,
//! and Zenoh's own count of what its congestion control dropped (docs/zenoh.md).
//!
//! One session per process: two sessions of one run would each listen on `[zenoh] listen` and
//! meet each other as peers. The session enables Zenoh's admin space (read-only) so that the
//! sink can read back, from its own session, how many messages Zenoh's transmission queues
//! dropped (`CongestionControl::Drop`, the `stats` feature): a put that Zenoh drops is not an
//! error and returns nothing that says so.

use crate::config::ValidZenohConfig;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};

/// A run's Zenoh session.
#[derive(Clone)]
pub struct ZenohSession {
    pub session: zenoh::Session,
    /// "peer" or "client" (the admin space's key has it).
    mode: String,
    /// Zenoh's congestion count is session-wide: the first sink started reports it, the others
    /// do not (so the summary counts each drop once).
    drops_claimed: Arc<AtomicBool>,
}

/// What the startup error says about the session it could not open.
fn describe(c: &ValidZenohConfig) -> String {
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    format!(
        "mode {}, connect [{}], listen [{}], multicast scouting {}",
        c.mode,
        list(&c.connect),
        list(&c.listen),
        if c.multicast_scouting { "on" } else { "off" }
    )
}

/// The Zenoh configuration of `c` (JSON5 keys of Zenoh's own config file).
pub fn zenoh_config(c: &ValidZenohConfig) -> Result<zenoh::Config, String> {
    let mut z = zenoh::Config::default();
    let json = |v: &[String]| serde_json::to_string(v).expect("strings serialise");
    let mut set = |k: &str, v: String| {
        z.insert_json5(k, &v)
            .map_err(|e| format!("zenoh config {k} = {v}: {e}"))
    };
    set("mode", format!("{:?}", c.mode))?;
    set("connect/endpoints", json(&c.connect))?;
    if !c.listen.is_empty() {
        set("listen/endpoints", json(&c.listen))?;
    }
    set(
        "scouting/multicast/enabled",
        c.multicast_scouting.to_string(),
    )?;
    if !c.connect.is_empty() {
        // Reach one `connect` endpoint within the timeout, or fail the start naming them;
        // 0: start at once and keep trying in the background.
        let wait = c.connect_timeout_ms > 0;
        set("connect/exit_on_failure", wait.to_string())?;
        set(
            "connect/timeout_ms",
            if wait {
                c.connect_timeout_ms.to_string()
            } else {
                "-1".into()
            },
        )?;
    }
    // Read-only admin space: the sink reads Zenoh's drop count from it (and a fleet operator
    // can look at the session with Zenoh's own tools).
    set("adminspace/enabled", "true".into())?;
    set("adminspace/permissions/read", "true".into())?;
    set("adminspace/permissions/write", "false".into())?;
    Ok(z)
}

impl ZenohSession {
    /// Open the session of `[zenoh]`; an endpoint that cannot be used (a listen address that
    /// does not bind, no connect endpoint reached within `connect_timeout_ms`) is an error
    /// naming the session's endpoints.
    pub async fn open(c: &ValidZenohConfig) -> Result<ZenohSession, String> {
        let z = zenoh_config(c)?;
        let session = zenoh::open(z)
            .await
            .map_err(|e| format!("zenoh: cannot open the session ({}): {e}", describe(c)))?;
        tracing::info!(zid = %session.zid(), "zenoh session open ({})", describe(c));
        Ok(ZenohSession {
            session,
            mode: c.mode.clone(),
            drops_claimed: Arc::new(AtomicBool::new(false)),
        })
    }

    /// True for the first caller only: that sink reports Zenoh's session-wide drop count.
    pub fn claim_drop_count(&self) -> bool {
        !self.drops_claimed.swap(true, Relaxed)
    }

    /// Messages Zenoh's transmission queues have dropped so far in this session (congestion
    /// control `Drop`: a peer or router that does not take them fast enough), from the
    /// session's own admin space; `None` if it did not answer.
    pub async fn congestion_drops(&self) -> Option<u64> {
        // The admin space is not a queryable of the session's own face: no locality limit
        // (the key names this session's zid, so no other node answers).
        let sel = format!("@/{}/{}?_stats=true", self.session.zid(), self.mode);
        let replies = match self
            .session
            .get(&sel)
            .timeout(std::time::Duration::from_secs(2))
            .await
        {
            Ok(r) => r,
            Err(e) => {
                tracing::debug!("zenoh: query {sel}: {e}");
                return None;
            }
        };
        while let Ok(r) = replies.recv_async().await {
            match r.result() {
                Ok(s) => {
                    let v: serde_json::Value =
                        serde_json::from_slice(&s.payload().to_bytes()).ok()?;
                    let n = v["stats"]["tx_n_dropped"].as_u64();
                    tracing::debug!("zenoh: {sel}: tx_n_dropped {n:?}");
                    return n;
                }
                Err(e) => tracing::debug!("zenoh: {sel}: error reply {e:?}"),
            }
        }
        tracing::debug!("zenoh: {sel}: no reply");
        None
    }

    /// Close the session (what is queued is sent first, as far as Zenoh can).
    pub async fn close(&self) {
        let _ = self.session.close().await;
    }
}
