//! Mouse and keys as the window reads them: what is held, the drags accumulated between
//! redraws, and what they ask of the camera ([`Input::move_camera`]) or of the edits
//! ([`ButtonIntent`]). Which key does what is [`super::keys`]' table.

use super::camera::{CameraController, FlyInput};
use super::edit::CLICK_SLOP;
use super::keys::Action;
use glam::DVec3;
use std::time::Duration;
use winit::dpi::PhysicalPosition;
use winit::event::MouseButton;
use winit::keyboard::ModifiersState;

/// A tap of a movement key moves at least this long's worth.
const TAP: Duration = Duration::from_millis(50);

/// Mouse and keys as the camera reads them.
#[derive(Default)]
pub struct Input {
    pub mods: ModifiersState,
    pub cursor: Option<PhysicalPosition<f64>>,
    pub left: bool,
    pub right: bool,
    /// Where the left button went down (outside the HUD), and how far the cursor went from
    /// there since (a release within `CLICK_SLOP` is a click: it picks).
    press: Option<PhysicalPosition<f64>>,
    travel: f64,
    /// A light being moved in the view plane (Shift+left or middle drag).
    pub light_drag: Option<LightDrag>,
    /// Drag accumulated since the last redraw, (dx, dy) in pixels.
    orbit: (f64, f64),
    look: (f64, f64),
    /// Fly keys held, per axis (forward, right, up): [positive, negative].
    held: [[bool; 2]; 3],
    /// Movement keys pressed and released before a redraw saw them held.
    taps: FlyInput,
}

/// A light drag: the light, its position when the drag began (as written, and as posed), and
/// the cursor's offset since, in window pixels. The position follows from the start and the
/// whole offset, so a drag back to where it began puts the light back exactly.
#[derive(Clone, Copy)]
pub struct LightDrag {
    pub light: usize,
    pub start: DVec3,
    pub posed: DVec3,
    pub offset: (f64, f64),
}

/// What a mouse button asks beyond the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ButtonIntent {
    Nothing,
    /// A click (press and release within the slop): select what is at this window position.
    Pick(PhysicalPosition<f64>),
    /// The light drag of this light ended.
    LightDropped(usize),
}

fn axis(held: [bool; 2]) -> f64 {
    held[0] as i32 as f64 - held[1] as i32 as f64
}

fn component(f: &mut FlyInput, axis: usize) -> &mut f64 {
    match axis {
        0 => &mut f.forward,
        1 => &mut f.right,
        _ => &mut f.up,
    }
}

impl Input {
    /// The fly keys held, as the camera reads them.
    pub fn fly(&self) -> FlyInput {
        FlyInput { forward: axis(self.held[0]), right: axis(self.held[1]), up: axis(self.held[2]) }
    }

    pub fn speed_modifier(&self) -> f64 {
        if self.mods.shift_key() {
            4.0
        } else if self.mods.control_key() {
            0.25
        } else {
            1.0
        }
    }

    /// Something held moves the camera (or a light).
    pub fn active(&self) -> bool {
        self.left || self.right || self.light_drag.is_some() || !self.fly().is_zero()
    }

    /// A fly key of the table went down or up; false if `action` is no fly key.
    pub fn fly_key(&mut self, action: Action, down: bool) -> bool {
        let Some((axis, sign)) = action.fly_axis() else { return false };
        let held = &mut self.held[axis][(sign < 0.0) as usize];
        if down && !*held {
            // A press always moves a little, even if released before the next redraw.
            *component(&mut self.taps, axis) = sign;
        }
        *held = down;
        true
    }

    /// The cursor moved to `position`; whether a redraw should follow.
    pub fn cursor_moved(&mut self, position: PhysicalPosition<f64>) -> bool {
        let mut redraw = false;
        if let Some(old) = self.cursor {
            let (dx, dy) = (position.x - old.x, position.y - old.y);
            if let Some(p) = self.press {
                self.travel = self.travel.max((position.x - p.x).hypot(position.y - p.y));
            }
            if let Some(d) = &mut self.light_drag {
                d.offset.0 += dx;
                d.offset.1 += dy;
                redraw = true;
            } else if self.left {
                self.orbit.0 += dx;
                self.orbit.1 += dy;
            } else if self.right {
                self.look.0 += dx;
                self.look.1 += dy;
            }
            redraw |= self.left || self.right;
        }
        self.cursor = Some(position);
        redraw
    }

    /// A mouse button went down or up (outside the HUD). `light`: the selected light, with
    /// its position as written and as posed, which a Shift+left or middle drag moves.
    pub fn mouse_button(
        &mut self,
        button: MouseButton,
        down: bool,
        light: Option<(usize, DVec3, DVec3)>,
    ) -> ButtonIntent {
        let drag_button = match button {
            MouseButton::Left => self.mods.shift_key(),
            MouseButton::Middle => true,
            _ => false,
        };
        if let (true, true, Some((i, start, posed)), None) = (down, drag_button, light, self.light_drag) {
            self.light_drag = Some(LightDrag { light: i, start, posed, offset: (0.0, 0.0) });
            return ButtonIntent::Nothing;
        }
        let mut intent = ButtonIntent::Nothing;
        if !down && matches!(button, MouseButton::Left | MouseButton::Middle) {
            if let Some(d) = self.light_drag.take() {
                intent = ButtonIntent::LightDropped(d.light);
                if button == MouseButton::Middle || !self.left {
                    return intent;
                }
            }
        }
        match button {
            MouseButton::Left => {
                if down {
                    self.press = self.cursor;
                    self.travel = 0.0;
                } else if self.left {
                    if let Some(at) = self.press.take().filter(|_| self.travel <= CLICK_SLOP) {
                        intent = ButtonIntent::Pick(at);
                    }
                }
                self.left = down;
            }
            MouseButton::Right => self.right = down,
            _ => {}
        }
        intent
    }

    /// The window lost the focus: keys released meanwhile never reach us.
    pub fn focus_lost(&mut self) {
        let (taps, cursor) = (self.taps, self.cursor);
        *self = Input { cursor, taps, ..Input::default() };
    }

    /// Applies what was dragged and held since the last redraw, `dt` ago, to the camera.
    pub fn move_camera(&mut self, controller: &mut CameraController, dt: Duration) {
        let (ox, oy) = std::mem::take(&mut self.orbit);
        let (lx, ly) = std::mem::take(&mut self.look);
        controller.orbit(ox, oy);
        controller.look(lx, ly);
        let held = self.fly();
        let modifier = self.speed_modifier();
        controller.fly(held, dt.as_secs_f64(), modifier);
        let taps = std::mem::take(&mut self.taps);
        // Taps not also held: a press and release between two redraws.
        let tap_only = FlyInput {
            forward: if held.forward == 0.0 { taps.forward } else { 0.0 },
            right: if held.right == 0.0 { taps.right } else { 0.0 },
            up: if held.up == 0.0 { taps.up } else { 0.0 },
        };
        controller.fly(tap_only, TAP.as_secs_f64(), modifier);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Q flies down whatever the mouse does (it used to quit unless the right button was held).
    #[test]
    fn q_and_e_fly_down_and_up() {
        let mut i = Input::default();
        assert!(i.fly_key(Action::FlyDown, true));
        assert_eq!(i.fly().up, -1.0);
        assert!(i.fly_key(Action::FlyUp, true));
        assert_eq!(i.fly().up, 0.0);
        i.fly_key(Action::FlyDown, false);
        assert_eq!(i.fly().up, 1.0);
        assert!(!i.fly_key(Action::Quit, true));
        assert!(i.active());
    }

    #[test]
    fn a_still_press_picks_and_a_drag_does_not() {
        let mut i = Input::default();
        let at = PhysicalPosition::new(10.0, 10.0);
        i.cursor_moved(at);
        i.mouse_button(MouseButton::Left, true, None);
        assert_eq!(i.mouse_button(MouseButton::Left, false, None), ButtonIntent::Pick(at));
        i.mouse_button(MouseButton::Left, true, None);
        assert!(i.cursor_moved(PhysicalPosition::new(60.0, 10.0)));
        assert_eq!(i.mouse_button(MouseButton::Left, false, None), ButtonIntent::Nothing);
        assert_eq!(i.orbit, (50.0, 0.0));
    }
}
