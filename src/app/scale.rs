//! The window's resolution scale: the frame buffer's size for a divisor, and the divisor a
//! window needs to fit the device's frame buffers.

/// Frame-buffer size for a window of `window` pixels at divisor `div`.
pub fn render_size(window: [u32; 2], div: u32) -> [u32; 2] {
    [window[0].div_ceil(div).max(1), window[1].div_ceil(div).max(1)]
}

/// The divisor a window of `window` pixels is traced at when `div` is asked for and the
/// device's frame buffers hold `most` pixels: `div`, doubled until the frame fits (the
/// interactive modes trace one frame buffer; a 5K window on lavapipe's 128 MiB bindings is
/// traced at 1/2).
pub fn fit_divisor(window: [u32; 2], div: u32, most: u64) -> u32 {
    let mut d = div.max(1);
    while {
        let [w, h] = render_size(window, d);
        w as u64 * h as u64 > most
    } {
        d *= 2;
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_past_the_frame_buffers_is_traced_at_a_scale_that_fits() {
        let most = 134_217_728 / 16;
        assert_eq!(fit_divisor([3840, 2160], 1, most), 1);
        assert_eq!(fit_divisor([4096, 2160], 1, most), 2);
        assert_eq!(fit_divisor([7680, 4320], 1, most), 2);
        assert_eq!(fit_divisor([7680, 4320], 2, most), 2);
        assert_eq!(fit_divisor([16384, 16384], 1, most), 8);
        assert_eq!(fit_divisor([640, 480], 4, most), 4);
    }

    #[test]
    fn render_sizes_round_up_and_never_vanish() {
        assert_eq!(render_size([640, 480], 1), [640, 480]);
        assert_eq!(render_size([641, 481], 2), [321, 241]);
        assert_eq!(render_size([1, 1], 4), [1, 1]);
    }
}
