//! Fuzzes the OBJ reader: any text gives a mesh or an error, never a panic; every face of a
//! parsed mesh is in range, and what parses writes and reads back to the same mesh. The
//! labelable-vertex scan reads the same text: never a panic, one flag per `v` line.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::obj::{labelable_vertices_in, parse_obj, write_obj_to};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let surface = labelable_vertices_in(&text);
    if let Ok(mesh) = parse_obj(&text, Path::new("fuzz.obj")) {
        if let Some(s) = &surface {
            assert_eq!(s.len(), mesh.num_vertices(), "one flag per vertex");
        }
        assert_eq!(mesh.first_face_out_of_range(), None, "face past the last vertex accepted");
        let mut out = Vec::new();
        write_obj_to(&mut out, &mesh).expect("write to memory");
        let back = parse_obj(&String::from_utf8_lossy(&out), Path::new("out.obj"));
        let back = back.expect("re-parse");
        assert_eq!(back.num_vertices(), mesh.num_vertices());
        assert_eq!(back.faces, mesh.faces);
    }
});
