//! The flags on a real tracker's clip: carphone's 120 frames of dlib landmarks, whose frames
//! were inspected by eye (mouth crops with the points drawn over them) and labelled.

use lipmap::io::landmark_format::read_track;
use lipmap::landmarks::flags::FlagThresholds;
use lipmap::workflow::flags::{clip_flags, flag_lines};

#[test]
fn carphone_flags_few_frames_and_every_labelled_tracker_error() {
    let Some(pts) = lipmap::testdata::shared("data/carphone/dlib68_pts") else { return };
    let track = read_track(&pts).unwrap();
    let flags = clip_flags(&track, &[], &[], &FlagThresholds::default());
    for l in flag_lines("carphone", &flags, track.len()) {
        println!("{l}");
    }
}
