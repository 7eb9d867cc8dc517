//! `[zenoh]`: the one Zenoh session a run opens, its value checks, and the endpoint and key
//! checks that the Zenoh source and sink use too.

use serde::{Deserialize, Serialize};

/// `[zenoh]`: the one Zenoh session a run opens when a source or sink uses Zenoh.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ZenohConfig {
    /// "peer" (meets other peers directly, and routers) or "client" (through a router only).
    #[serde(default = "default_zenoh_mode")]
    pub mode: String,
    /// Endpoints to connect to, e.g. `tcp/192.168.1.10:7447`.
    #[serde(default)]
    pub connect: Vec<String>,
    /// Endpoints to listen on, e.g. `tcp/0.0.0.0:7447` (peer mode; empty = Zenoh's default).
    #[serde(default)]
    pub listen: Vec<String>,
    /// Find peers and routers by UDP multicast scouting.
    #[serde(default = "yes")]
    pub multicast_scouting: bool,
    /// With `connect` endpoints: how long the start waits to reach one, ms; none reached =
    /// a startup error naming them. 0 = do not wait (keep trying in the background).
    #[serde(default = "default_zenoh_connect_timeout_ms")]
    pub connect_timeout_ms: u64,
}

fn default_zenoh_mode() -> String {
    "peer".into()
}
fn yes() -> bool {
    true
}
fn default_zenoh_connect_timeout_ms() -> u64 {
    5_000
}

impl Default for ZenohConfig {
    fn default() -> Self {
        ZenohConfig {
            mode: default_zenoh_mode(),
            connect: Vec::new(),
            listen: Vec::new(),
            multicast_scouting: true,
            connect_timeout_ms: default_zenoh_connect_timeout_ms(),
        }
    }
}

/// The Zenoh link protocols this build's session can use (the crate's transport features).
pub const ZENOH_TRANSPORTS: &[&str] = &["tcp", "udp"];

crate::valid_settings!(
    /// `[zenoh]` that passed [`ZenohConfig::validate`]: the only form a session is opened from.
    ValidZenohConfig,
    ZenohConfig
);

impl ZenohConfig {
    /// Every value check, one message per mistake, each starting with its key.
    pub fn validate(self) -> Result<ValidZenohConfig, crate::settings::SettingsErrors> {
        let mut e = Vec::new();
        if !["peer", "client"].contains(&self.mode.as_str()) {
            e.push(format!(
                "mode: must be \"peer\" or \"client\", got {:?}",
                self.mode
            ));
        }
        for (key, list) in [("connect", &self.connect), ("listen", &self.listen)] {
            for (i, ep) in list.iter().enumerate() {
                if let Err(m) = check_zenoh_endpoint(ep) {
                    e.push(format!("{key}[{i}]: {m}"));
                }
            }
        }
        if self.mode == "client" && !self.listen.is_empty() {
            e.push("listen: a client does not listen (mode = \"peer\" to listen)".into());
        }
        if self.mode == "client" && self.connect.is_empty() && !self.multicast_scouting {
            e.push(
                "connect: a client needs a router: give its endpoint, or multicast_scouting = true to find one"
                    .into(),
            );
        }
        crate::settings::SettingsErrors::check("zenoh", e, ValidZenohConfig::checked(self))
    }
}

/// A Zenoh endpoint `PROTO/HOST:PORT` with a transport this build has.
fn check_zenoh_endpoint(ep: &str) -> Result<(), String> {
    let Some((proto, addr)) = ep.split_once('/') else {
        return Err(format!(
            "{ep:?} is not an endpoint (PROTO/HOST:PORT, e.g. tcp/127.0.0.1:7447)"
        ));
    };
    if !ZENOH_TRANSPORTS.contains(&proto) {
        return Err(format!(
            "{ep:?}: transport {proto:?} is not in this build (one of {})",
            ZENOH_TRANSPORTS.join(", ")
        ));
    }
    // Zenoh's own suffixes (`?metadata`, then `#config`) are its business, but their form is
    // checked as Zenoh's parser checks it (`EndPoint::try_from`): each one present is a
    // non-empty `KEY=VALUE;…` list with no empty key, `?` before `#`. The address must have a
    // port.
    let (addr, suffix) = match addr.find(['#', '?']) {
        Some(i) => (&addr[..i], &addr[i..]),
        None => (addr, ""),
    };
    let (meta, conf) = match suffix.find('#') {
        Some(i) => (&suffix[..i], Some(&suffix[i + 1..])),
        None => (suffix, None),
    };
    let meta = meta.strip_prefix('?');
    let well_formed = |p: &str| {
        let mut items = p.split(';').filter(|i| !i.is_empty()).peekable();
        items.peek().is_some() && items.all(|i| !i.split('=').next().unwrap_or("").is_empty())
    };
    for (part, sep) in [(meta, '?'), (conf, '#')] {
        match part {
            Some(p) if (sep == '#' && p.contains('?')) || !well_formed(p) => {
                return Err(format!(
                    "{ep:?}: Zenoh's options after '{sep}' must be KEY=VALUE[;KEY=VALUE…] (an empty part, an empty key, or '?' after '#', is refused by Zenoh)"
                ));
            }
            _ => {}
        }
    }
    match addr.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => Ok(()),
        _ => Err(format!(
            "{ep:?}: the address needs HOST:PORT (port 0–65535)"
        )),
    }
}

/// A Zenoh key: non-empty, no empty chunk (`a//b`), no leading/trailing `/`; `wildcards` allows
/// `*` and `**` chunks (a subscription), else none (a publication).
pub fn check_zenoh_key(key: &str, wildcards: bool) -> Result<(), String> {
    if key.is_empty() {
        return Err("empty key".into());
    }
    if key.starts_with('/') || key.ends_with('/') || key.contains("//") {
        return Err(format!(
            "{key:?}: a key has no leading, trailing or doubled '/'"
        ));
    }
    for chunk in key.split('/') {
        let wild = chunk.contains('*') || chunk.contains('$');
        if wild && !wildcards {
            return Err(format!(
                "{key:?}: a published key names one resource (no '*')"
            ));
        }
        if wild && chunk != "*" && chunk != "**" && !chunk.contains("$*") {
            return Err(format!("{key:?}: bad wildcard chunk {chunk:?}"));
        }
        if chunk.contains(['#', '?']) {
            return Err(format!("{key:?}: '#' and '?' are not allowed in a key"));
        }
    }
    Ok(())
}

/// What a config naming Zenoh is told by a build without it.
pub const ZENOH_NOT_BUILT: &str =
    "zenoh needs a build with Zenoh support (cargo build --release --features zenoh)";
