//! What the user asked for (`--graphics`, `LIPMAP_GRAPHICS`), the parts of the environment
//! that matter (tmux, SSH), and the startup decision made from them.

use ratatui_image::picker::ProtocolType;
use std::str::FromStr;

/// Environment variable read when `--graphics` is not given.
pub const GRAPHICS_ENV: &str = "LIPMAP_GRAPHICS";

/// What the user asked for with `--graphics` or `LIPMAP_GRAPHICS`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum GraphicsChoice {
    /// Query the terminal; never inside tmux or over SSH.
    #[default]
    Auto,
    Halfblocks,
    Sixel,
    Kitty,
    Iterm2,
}

impl GraphicsChoice {
    pub const NAMES: &'static str = "auto, halfblocks, sixel, kitty, iterm2";

    /// The choice from the command-line flag, else from `LIPMAP_GRAPHICS` (`env_value`),
    /// else auto. An empty variable counts as unset.
    ///
    /// # Errors
    /// When the variable holds an unknown name (the message names the variable).
    pub fn resolve(flag: Option<Self>, env_value: Option<&str>) -> Result<Self, String> {
        if let Some(c) = flag {
            return Ok(c);
        }
        match env_value.map(str::trim).filter(|v| !v.is_empty()) {
            None => Ok(Self::Auto),
            Some(v) => v.parse().map_err(|e| format!("{GRAPHICS_ENV}={v}: {e}")),
        }
    }

    /// `resolve` with the process's `LIPMAP_GRAPHICS`.
    ///
    /// # Errors
    /// As `resolve`.
    pub fn from_flag_or_env(flag: Option<Self>) -> Result<Self, String> {
        Self::resolve(flag, std::env::var(GRAPHICS_ENV).ok().as_deref())
    }
}

impl FromStr for GraphicsChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(Self::Auto),
            "halfblocks" | "half-blocks" | "halfblock" => Ok(Self::Halfblocks),
            "sixel" => Ok(Self::Sixel),
            "kitty" => Ok(Self::Kitty),
            "iterm2" | "iterm" => Ok(Self::Iterm2),
            other => Err(format!("unknown graphics mode `{other}` (expected {})", Self::NAMES)),
        }
    }
}

/// The parts of the environment the decision depends on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TermEnv {
    /// `$TMUX` is set: images need passthrough, which tmux often drops.
    pub tmux: bool,
    /// `$SSH_CONNECTION` or `$SSH_TTY` is set: every image crosses the network.
    pub ssh: bool,
}

impl TermEnv {
    /// From a variable lookup (empty values count as unset), so tests need no process env.
    pub fn from_lookup(var: impl Fn(&str) -> Option<String>) -> Self {
        let set = |n: &str| var(n).is_some_and(|v| !v.is_empty());
        Self { tmux: set("TMUX"), ssh: set("SSH_CONNECTION") || set("SSH_TTY") }
    }

    pub fn from_process() -> Self {
        Self::from_lookup(|n| std::env::var(n).ok())
    }
}

/// What to do at startup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// Half-blocks: asked for (`None`), or auto mode's reason, shown in the status line.
    HalfBlocks(Option<&'static str>),
    /// Ask the terminal which protocol it speaks (auto mode on a local terminal).
    Query,
    /// Use this protocol (asked for explicitly); the query only supplies the cell size.
    Force(ProtocolType),
}

/// The startup decision for a choice in an environment. Explicit protocols are honoured
/// inside tmux and over SSH; auto mode is not, since a protocol there is slow or broken.
pub fn decide(choice: GraphicsChoice, env: TermEnv) -> Decision {
    match choice {
        GraphicsChoice::Halfblocks => Decision::HalfBlocks(None),
        GraphicsChoice::Sixel => Decision::Force(ProtocolType::Sixel),
        GraphicsChoice::Kitty => Decision::Force(ProtocolType::Kitty),
        GraphicsChoice::Iterm2 => Decision::Force(ProtocolType::Iterm2),
        GraphicsChoice::Auto if env.tmux => Decision::HalfBlocks(Some("inside tmux")),
        GraphicsChoice::Auto if env.ssh => Decision::HalfBlocks(Some("over SSH")),
        GraphicsChoice::Auto => Decision::Query,
    }
}

pub fn protocol_name(p: ProtocolType) -> &'static str {
    match p {
        ProtocolType::Halfblocks => "half-blocks",
        ProtocolType::Sixel => "sixel",
        ProtocolType::Kitty => "kitty",
        ProtocolType::Iterm2 => "iterm2",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(tmux: bool, ssh: bool) -> TermEnv {
        TermEnv { tmux, ssh }
    }

    #[test]
    fn auto_queries_only_on_a_local_plain_terminal() {
        use GraphicsChoice as C;
        let forced = [
            (C::Sixel, ProtocolType::Sixel),
            (C::Kitty, ProtocolType::Kitty),
            (C::Iterm2, ProtocolType::Iterm2),
        ];
        for (tmux, ssh) in [(false, false), (true, false), (false, true), (true, true)] {
            let e = env(tmux, ssh);
            // Explicit requests win everywhere, tmux and SSH included.
            for (c, p) in forced {
                assert_eq!(decide(c, e), Decision::Force(p));
            }
            assert_eq!(decide(C::Halfblocks, e), Decision::HalfBlocks(None));
            let auto = decide(C::Auto, e);
            match (tmux, ssh) {
                (false, false) => assert_eq!(auto, Decision::Query),
                (true, _) => assert_eq!(auto, Decision::HalfBlocks(Some("inside tmux"))),
                (false, true) => assert_eq!(auto, Decision::HalfBlocks(Some("over SSH"))),
            }
        }
    }

    #[test]
    fn environment_variables_feed_the_decision() {
        let vars = |pairs: &'static [(&'static str, &'static str)]| {
            move |n: &str| pairs.iter().find(|(k, _)| *k == n).map(|(_, v)| v.to_string())
        };
        assert_eq!(TermEnv::from_lookup(vars(&[])), env(false, false));
        assert_eq!(
            TermEnv::from_lookup(vars(&[("TMUX", "/tmp/tmux-0/default,1,0")])),
            env(true, false)
        );
        assert_eq!(
            TermEnv::from_lookup(vars(&[("SSH_CONNECTION", "10.0.0.2 5 10.0.0.1 22")])),
            env(false, true)
        );
        assert_eq!(TermEnv::from_lookup(vars(&[("SSH_TTY", "/dev/pts/3")])), env(false, true));
        // Empty values are unset (e.g. `TMUX= lipmap tui …`).
        assert_eq!(TermEnv::from_lookup(vars(&[("TMUX", ""), ("SSH_TTY", "")])), env(false, false));

        use GraphicsChoice as C;
        // Flag beats variable; variable beats the default; empty variable is unset.
        assert_eq!(C::resolve(Some(C::Halfblocks), Some("kitty")), Ok(C::Halfblocks));
        assert_eq!(C::resolve(None, Some("Kitty")), Ok(C::Kitty));
        assert_eq!(C::resolve(None, Some(" sixel ")), Ok(C::Sixel));
        assert_eq!(C::resolve(None, Some("")), Ok(C::Auto));
        assert_eq!(C::resolve(None, None), Ok(C::Auto));
        let err = C::resolve(None, Some("png")).unwrap_err();
        assert!(err.contains("LIPMAP_GRAPHICS=png") && err.contains("kitty"), "{err}");
        // Over SSH with the variable set to a protocol, it is used; set to auto, it is not.
        let ssh = env(false, true);
        assert_eq!(
            decide(C::resolve(None, Some("sixel")).unwrap(), ssh),
            Decision::Force(ProtocolType::Sixel)
        );
        assert!(matches!(
            decide(C::resolve(None, Some("auto")).unwrap(), ssh),
            Decision::HalfBlocks(_)
        ));
    }
}
