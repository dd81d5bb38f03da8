//! The window's keys and mouse, in one table: the event handling looks keys up here
//! ([`action`]), and the HUD's key list, `irt view --help` ([`help`]) and the README's keys
//! block ([`markdown`], tied by a test) are rendered from it, so they cannot disagree.

use winit::keyboard::KeyCode;

/// What a key or a mouse gesture does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Left drag.
    Orbit,
    /// Right drag.
    Look,
    FlyForward,
    FlyLeft,
    FlyBack,
    FlyRight,
    FlyDown,
    FlyUp,
    /// The wheel.
    FlySpeed,
    /// Shift / Ctrl held: movement x4 / x0.25.
    SpeedModifier,
    Frame,
    Reset,
    PrintCamera,
    SwitchMode,
    /// Keys 1..4: the shadow mode of [`super::hud::SHADOW_CHOICES`] at this index.
    Shadows(u8),
    /// Maximum ray depth up (+1) or down (-1).
    Depth(i8),
    /// Resolution scale coarser (+1) or finer (-1).
    Scale(i8),
    /// Every volume's isovalues down (-1) or up (+1) by a fiftieth of its samples' range.
    Iso(i8),
    /// Every volume's look: the next of iso, MIP, DVR.
    VolumeLook,
    Screenshot,
    Hud,
    /// Left click.
    Pick,
    /// Shift+left or middle drag.
    DragLight,
    /// The selected light farther (+1) or nearer (-1).
    LightDepth(i8),
    NextLight,
    NextMaterial,
    SaveScene,
    PlayPause,
    /// Playback speed down (-1) or up (+1).
    PlaySpeed(i8),
    Quit,
}

impl Action {
    /// A fly key: held, it moves the camera; `(axis, sign)` with axis 0 forward, 1 right, 2 up.
    pub fn fly_axis(self) -> Option<(usize, f64)> {
        Some(match self {
            Action::FlyForward => (0, 1.0),
            Action::FlyBack => (0, -1.0),
            Action::FlyRight => (1, 1.0),
            Action::FlyLeft => (1, -1.0),
            Action::FlyUp => (2, 1.0),
            Action::FlyDown => (2, -1.0),
            _ => return None,
        })
    }
}

/// One row of the table: how it is written for people, the keys that do it (none for the
/// mouse and the held modifiers, which the input handling reads as such) and what it does.
pub struct Binding {
    pub shown: &'static str,
    pub keys: &'static [(KeyCode, Action)],
    /// The action of a mouse row (keys rows name theirs per key).
    pub mouse: Option<Action>,
    pub words: &'static str,
}

const fn mouse(shown: &'static str, action: Action, words: &'static str) -> Binding {
    Binding { shown, keys: &[], mouse: Some(action), words }
}

const fn keys(shown: &'static str, keys: &'static [(KeyCode, Action)], words: &'static str) -> Binding {
    Binding { shown, keys, mouse: None, words }
}

use Action as A;
use KeyCode as K;

/// Every binding of the window, in the order people read them.
pub const TABLE: &[Binding] = &[
    mouse("left drag", A::Orbit, "orbit around the focus point"),
    mouse("right drag", A::Look, "look around"),
    keys(
        "`W` `A` `S` `D`",
        &[(K::KeyW, A::FlyForward), (K::KeyA, A::FlyLeft), (K::KeyS, A::FlyBack), (K::KeyD, A::FlyRight)],
        "fly forward / left / back / right",
    ),
    keys("`Q` / `E`", &[(K::KeyQ, A::FlyDown), (K::KeyE, A::FlyUp)], "fly down / up"),
    mouse("wheel", A::FlySpeed, "fly speed x1.25 per notch"),
    mouse("`Shift` / `Ctrl` (held)", A::SpeedModifier, "move x4 faster / x0.25 finer"),
    keys("`F`", &[(K::KeyF, A::Frame)], "frame the scene (fit its bounding sphere)"),
    keys("`R`", &[(K::KeyR, A::Reset)], "reset to the scene's camera"),
    keys("`C`", &[(K::KeyC, A::PrintCamera)], "print the camera as a TOML `[camera]` table on stdout"),
    keys("`M`", &[(K::KeyM, A::SwitchMode)], "switch between frameless and conventional"),
    keys(
        "`1` `2` `3` `4`",
        &[
            (K::Digit1, A::Shadows(0)),
            (K::Digit2, A::Shadows(1)),
            (K::Digit3, A::Shadows(2)),
            (K::Digit4, A::Shadows(3)),
        ],
        "shadows: hard / bundle:4 / bundle:16 / shell",
    ),
    keys(
        "`+` / `-`",
        &[
            (K::Equal, A::Depth(1)),
            (K::NumpadAdd, A::Depth(1)),
            (K::Minus, A::Depth(-1)),
            (K::NumpadSubtract, A::Depth(-1)),
        ],
        "maximum ray depth up / down",
    ),
    keys(
        "`[` / `]`",
        &[(K::BracketLeft, A::Scale(1)), (K::BracketRight, A::Scale(-1))],
        "resolution scale down / up (1, 1/2, 1/4)",
    ),
    keys(
        "`U` / `I`",
        &[(K::KeyU, A::Iso(-1)), (K::KeyI, A::Iso(1))],
        "volumes: isovalue down / up by 1/50 of the samples' range",
    ),
    keys("`V`", &[(K::KeyV, A::VolumeLook)], "volumes: isosurfaces / MIP / DVR"),
    keys(
        "`P`",
        &[(K::KeyP, A::Screenshot)],
        "screenshot PNG (--screenshot FILE, else irt-YYYYmmdd-HHMMSS.png, UTC)",
    ),
    keys(
        "`H`",
        &[(K::KeyH, A::Hud)],
        "HUD panel on / off (else a compact status in the corner; a click on it opens the panel too)",
    ),
    mouse("left click", A::Pick, "select the object or light under the cursor (the HUD edits it)"),
    mouse("`Shift`+left drag, middle drag", A::DragLight, "move the selected light in the view plane"),
    keys(
        "`PgUp` / `PgDn`",
        &[(K::PageUp, A::LightDepth(1)), (K::PageDown, A::LightDepth(-1))],
        "move the selected light farther / nearer",
    ),
    keys("`L`", &[(K::KeyL, A::NextLight)], "select the next light"),
    keys("`K`", &[(K::KeyK, A::NextMaterial)], "the selected object's material: next kind"),
    keys("`T`", &[(K::KeyT, A::SaveScene)], "write the scene, with its edits, as TOML (--save FILE)"),
    keys("`Space`", &[(K::Space, A::PlayPause)], "play / pause an animated scene"),
    keys(
        "`,` / `.`",
        &[(K::Comma, A::PlaySpeed(-1)), (K::Period, A::PlaySpeed(1))],
        "animation speed /2 / x2",
    ),
    keys("`Esc`", &[(K::Escape, A::Quit)], "quit (so does closing the window)"),
];

/// The action of the key at physical position `code`, if the table has one.
pub fn action(code: KeyCode) -> Option<Action> {
    TABLE.iter().flat_map(|b| b.keys).find(|(k, _)| *k == code).map(|&(_, a)| a)
}

/// A row's keys as plain text (the README writes them as code).
pub fn plain(shown: &str) -> String {
    shown.replace('`', "")
}

/// `irt view --help`'s key list.
pub fn help() -> String {
    let mut s = String::from("Keys and mouse:\n");
    for b in TABLE {
        s += &format!("  {:<22}{}\n", plain(b.shown), plain(b.words));
    }
    s
}

/// The README's keys block, markers included.
pub fn markdown() -> String {
    let mut s = format!("{BEGIN}\n| key or mouse | action |\n|---|---|\n");
    for b in TABLE {
        s += &format!("| {} | {} |\n", b.shown, b.words);
    }
    s + END + "\n"
}

/// The README's keys block lies between these lines.
pub const BEGIN: &str = "<!-- keys: generated from src/app/keys.rs, do not edit by hand -->";
pub const END: &str = "<!-- /keys -->";

/// The keys block of `readme`, from [`BEGIN`] to [`END`] and its line end, if it has one.
pub fn readme_block(readme: &str) -> Option<&str> {
    let start = readme.find(BEGIN)?;
    let end = start + readme[start..].find(END)? + END.len();
    let end = if readme[end..].starts_with('\n') { end + 1 } else { end };
    Some(&readme[start..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A key does one thing, and every action the window handles has a row.
    #[test]
    fn each_key_once_and_every_action_listed() {
        let codes: Vec<KeyCode> = TABLE.iter().flat_map(|b| b.keys).map(|(k, _)| *k).collect();
        for (i, c) in codes.iter().enumerate() {
            assert!(!codes[i + 1..].contains(c), "{c:?} is bound twice");
        }
        assert_eq!(action(KeyCode::Escape), Some(Action::Quit));
        assert_eq!(action(KeyCode::KeyQ), Some(Action::FlyDown), "Q flies down; it does not quit");
        assert_eq!(action(KeyCode::KeyE), Some(Action::FlyUp));
        assert_eq!(action(KeyCode::KeyZ), None);
        for b in TABLE {
            assert!(b.keys.is_empty() != b.mouse.is_none(), "{}: keys or a mouse action", b.shown);
        }
    }

    #[test]
    fn readme_block_is_found_and_help_lists_every_row() {
        let md = markdown();
        assert_eq!(readme_block(&format!("intro\n{md}after\n")), Some(md.as_str()));
        assert_eq!(readme_block("no block"), None);
        let help = help();
        assert_eq!(help.lines().count(), TABLE.len() + 1);
        assert!(help.contains("Esc") && !help.contains('`'), "{help}");
    }
}
