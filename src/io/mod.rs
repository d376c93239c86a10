//! File formats, one module each. Every parser returns `FormatError`, which names the file
//! and the line (or field) at fault, so a bad file never panics and the user knows where.

pub mod error;
pub mod frames;
pub mod input;

pub use error::FormatError;
pub mod alignment_format;
pub mod atomic;
pub mod audio_track;
pub mod bounds_table;
pub mod dlib_xml;
pub mod eos_bin;
pub mod eos_csv;
pub mod file_kind;
pub mod htk_lab;
pub mod json_model;
pub mod landmark_format;
pub mod landmark_map_toml;
pub mod makehuman_target;
pub mod model_file;
pub mod model_source;
pub mod motion_csv;
pub mod names_table;
pub mod npy_model;
pub mod obj;
pub mod openface;
pub mod phone_table;
pub mod phones_csv;
pub mod pts;
pub mod textgrid;
pub mod track_csv;
pub mod viseme_table;
pub mod wav;
