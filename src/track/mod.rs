//! Landmark tracking inside lipmap with dlib's ensemble-of-regression-trees shape predictor
//! (Kazemi & Sullivan 2014), read from the user's own `shape_predictor_68_face_landmarks.dat`.
//!
//! One step per module: [`predictor_file`] reads dlib's serialized predictor, [`similarity`]
//! is the normalisation to the mean shape, [`cascade`] runs the trees; [`haar_file`] and
//! [`viola_jones`] find a face to start from, [`tracker`] follows it from frame to frame,
//! [`realign`] re-runs the cascade around the points a user corrected, carrying the others
//! with them by the predictor's own [`shape_prior`].
//! Start at [`cascade::run_cascade`], then [`tracker::FaceTracker::track_frame`].
//!
//! Coordinates: image pixels, x right, y down, 0-based pixel centres (as the rest of
//! lipmap); the cascade works in the face box's normalised frame ((0,0) its top-left,
//! (1,1) its bottom-right), converted once at its edges.

pub mod cascade;
pub mod haar_file;
pub mod lucas_kanade;
pub mod predictor_file;
pub mod realign;
pub mod shape_prior;
pub mod similarity;
pub mod tracker;
pub mod viola_jones;

pub use cascade::{CascadeStart, GrayImage, GrayView, gray_from_rgb, run_cascade};
pub use haar_file::{DEBIAN_CASCADE_PATH, HaarCascade, parse_haar_cascade, read_haar_cascade};
pub use predictor_file::{
    DEBIAN_PREDICTOR_PATH, Forest, ShapePredictor, parse_shape_predictor, read_shape_predictor,
};
pub use shape_prior::{HeldCarry, ShapePrior};
pub use similarity::{FaceBox, box_from_shape, similarity_scaled_rotation};
pub use viola_jones::{DetectOptions, Detection, detect_faces};
