//! Wavefront OBJ meshes, read and written with vertex order kept exactly as in the file:
//! for a morphable model the vertex index *is* the correspondence, so nothing is renumbered.
//!
//! Only `v` and `f` lines matter: `v x y z [w | r g b]` (extra numbers ignored) and
//! `f a b c …` polygons whose references may be `v`, `v/vt`, `v//vn` or `v/vt/vn`, 1-based
//! or negative (relative to the vertices read so far), and may point forward to vertices
//! defined later in the file. Everything else (`vt`, `vn`, `g`, `o`, `usemtl`, …) is skipped.
//! A general loader such as tobj renumbers vertices by first use; this one never does.

use crate::io::error::{FormatError, Result};
use crate::math::Point3;
use crate::model::Mesh;
use std::io::Write;
use std::path::Path;

/// Reads an OBJ file into a [`Mesh`], vertices in file order.
///
/// # Errors
/// Unreadable file, a malformed `v` or `f` line, an index of 0, or a face pointing past the
/// last vertex (or before the first, for a negative index): each names the line.
pub fn read_obj(path: &Path) -> Result<Mesh> {
    let bytes = super::input::read_input(path)?;
    let text = String::from_utf8_lossy(&bytes);
    let mesh = parse_obj(&text, path)?;
    if mesh.vertices.is_empty() {
        // A binary file or another format named .obj parses to nothing; say so.
        return Err(FormatError::whole(path, "no vertices (`v` lines): not an OBJ mesh"));
    }
    Ok(mesh)
}

/// Parses OBJ text; `path` is used only in error messages.
///
/// # Errors
/// As [`read_obj`].
///
/// ```
/// use std::path::Path;
/// let text = "v 0 0 0\nv 1 0 0\nf 3 1 2\nv 0 1 0\n"; // face points forward, kept as written
/// let mesh = lipmap::io::obj::parse_obj(text, Path::new("t.obj")).unwrap();
/// assert_eq!(mesh.faces, vec![vec![2, 0, 1]]);
/// ```
pub fn parse_obj(text: &str, path: &Path) -> Result<Mesh> {
    let mut vertices: Vec<Point3> = Vec::new();
    let mut faces: Vec<Vec<u32>> = Vec::new();
    // The line of each face, for errors found once all `v` lines are known.
    let mut face_lines: Vec<usize> = Vec::new();
    for (i, raw) in super::input::without_bom(text).lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut xyz = [0.0; 3];
                for (k, slot) in xyz.iter_mut().enumerate() {
                    let tok = tokens.next().ok_or_else(|| {
                        FormatError::at_line(path, line_no, format!("`v` needs 3 numbers: `{raw}`"))
                    })?;
                    *slot = tok.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                        FormatError::at_line(
                            path,
                            line_no,
                            format!("coordinate {} `{tok}` is not a finite number", k + 1),
                        )
                    })?;
                }
                vertices.push(Point3::new(xyz[0], xyz[1], xyz[2]));
            }
            Some("f") => {
                let mut face = Vec::with_capacity(4);
                for tok in tokens {
                    let v = tok.split('/').next().unwrap_or("");
                    let idx: i64 = v.parse().map_err(|_| {
                        FormatError::at_line(path, line_no, format!("bad vertex reference `{tok}`"))
                    })?;
                    let resolved = if idx > 0 {
                        idx - 1
                    } else if idx < 0 {
                        let r = vertices.len() as i64 + idx;
                        if r < 0 {
                            return Err(FormatError::at_line(
                                path,
                                line_no,
                                format!(
                                    "relative reference {idx} points before the first vertex \
                                     ({} read so far)",
                                    vertices.len()
                                ),
                            ));
                        }
                        r
                    } else {
                        return Err(FormatError::at_line(
                            path,
                            line_no,
                            "vertex reference 0 (OBJ indices start at 1)",
                        ));
                    };
                    let resolved = u32::try_from(resolved).map_err(|_| {
                        FormatError::at_line(path, line_no, format!("vertex index {idx} too large"))
                    })?;
                    face.push(resolved);
                }
                if face.len() < 3 {
                    return Err(FormatError::at_line(
                        path,
                        line_no,
                        format!("a face needs at least 3 vertices, got {}", face.len()),
                    ));
                }
                faces.push(face);
                face_lines.push(line_no);
            }
            _ => {}
        }
    }
    let mesh = Mesh { vertices, faces };
    if let Some((f, v)) = mesh.first_face_out_of_range() {
        return Err(FormatError::at_line(
            path,
            face_lines[f],
            format!(
                "face uses vertex {} but the file has only {} vertices",
                v as u64 + 1,
                mesh.vertices.len()
            ),
        ));
    }
    Ok(mesh)
}

/// Which vertices of an OBJ are head surface that landmarks can be labelled on: `false` for
/// vertices used only by faces of groups/objects named `helper-*` or `joint-*` (MakeHuman's
/// proxy shells, eyelashes and joint markers, which sit in front of or inside the skin).
/// `None` when the file has no such group (every vertex is eligible).
///
/// # Errors
/// When the file cannot be read.
pub fn labelable_vertices(path: &Path) -> Result<Option<Vec<bool>>> {
    let text = super::input::read_input_string(path)?;
    Ok(labelable_vertices_in(&text))
}

/// [`labelable_vertices`] on the text of an OBJ.
pub fn labelable_vertices_in(text: &str) -> Option<Vec<bool>> {
    vertices_outside_groups(text, |g| g.starts_with("helper-") || g.starts_with("joint-"))
}

/// Which vertices of an OBJ hide what lies behind them: the skin and the solid parts inside
/// it (MakeHuman's `helper-*-eye` eyeballs, teeth and tongue), not the see-through shells
/// (hair, clothing proxies, eyelashes) or joint markers. Without the eyeballs an eye socket's
/// back shows through the lids and takes the eye's landmarks. `None` when the file has no
/// such shell (every vertex occludes).
///
/// # Errors
/// When the file cannot be read.
pub fn occluding_vertices(path: &Path) -> Result<Option<Vec<bool>>> {
    let text = super::input::read_input_string(path)?;
    Ok(occluding_vertices_in(&text))
}

/// [`occluding_vertices`] on the text of an OBJ.
pub fn occluding_vertices_in(text: &str) -> Option<Vec<bool>> {
    let solid = |g: &str| g.ends_with("-eye") || g.ends_with("-teeth") || g.ends_with("-tongue");
    vertices_outside_groups(text, |g| {
        g.starts_with("joint-") || (g.starts_with("helper-") && !solid(g))
    })
}

/// Vertices used by a face of a group/object that `skip` does not name (`None` when no
/// group is skipped).
fn vertices_outside_groups(text: &str, skip: impl Fn(&str) -> bool) -> Option<Vec<bool>> {
    let is_aux = &skip;
    let (mut n_vertices, mut aux_seen, mut in_aux) = (0usize, false, false);
    let mut surface: Vec<bool> = Vec::new();
    for raw in text.lines() {
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => n_vertices += 1,
            Some("g" | "o") => {
                in_aux = tokens.next().is_some_and(is_aux);
                aux_seen |= in_aux;
            }
            Some("f") if !in_aux => {
                surface.resize(surface.len().max(n_vertices), false);
                for tok in tokens {
                    let Some(idx) = tok.split('/').next().and_then(|v| v.parse::<i64>().ok())
                    else {
                        continue;
                    };
                    let i = if idx > 0 { idx - 1 } else { n_vertices as i64 + idx };
                    if let Some(s) = usize::try_from(i).ok().and_then(|i| surface.get_mut(i)) {
                        *s = true;
                    }
                }
            }
            _ => {}
        }
    }
    surface.resize(n_vertices, false);
    aux_seen.then_some(surface)
}

/// Writes a mesh as OBJ: one `v` line per vertex in order (shortest exact decimal form,
/// so a read gives back the same f64), then 1-based `f` lines as stored (polygons kept).
///
/// # Errors
/// I/O errors, naming the file.
pub fn write_obj(path: &Path, mesh: &Mesh) -> Result<()> {
    super::atomic::write_atomic(path, |w| write_obj_to(w, mesh))
        .map_err(|e| FormatError::io(path, e))
}

/// Writes OBJ text to any writer (see [`write_obj`]).
///
/// # Errors
/// Errors of the writer; a vertex with a non-finite coordinate (`InvalidData` naming it):
/// lipmap never writes NaN or ±inf into an output.
pub fn write_obj_to<W: Write + ?Sized>(w: &mut W, mesh: &Mesh) -> std::io::Result<()> {
    if let Some(i) = mesh.vertices.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        let p = mesh.vertices[i];
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("vertex {} is ({}, {}, {}), not a point lipmap writes", i + 1, p.x, p.y, p.z),
        ));
    }
    writeln!(w, "# lipmap mesh: {} vertices, {} faces", mesh.vertices.len(), mesh.faces.len())?;
    for p in &mesh.vertices {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for f in &mesh.faces {
        w.write_all(b"f")?;
        for v in f {
            write!(w, " {}", *v as u64 + 1)?;
        }
        w.write_all(b"\n")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {

    #[test]
    fn a_byte_order_mark_before_the_first_vertex_is_skipped() {
        let mesh = parse_obj("\u{feff}v 1 2 3\nv 4 5 6\nv 7 8 9\nf 1 2 3\n", Path::new("m.obj"));
        assert_eq!(mesh.unwrap().vertices.len(), 3);
    }

    #[test]
    fn a_binary_file_named_obj_is_not_a_mesh() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("head.obj");
        std::fs::write(&p, [0u8, 159, 146, 150, 7, 0, 255]).unwrap();
        let e = read_obj(&p).unwrap_err().to_string();
        assert_eq!(e, format!("{}: no vertices (`v` lines): not an OBJ mesh", p.display()));
    }
    use super::*;

    #[test]
    fn helper_and_joint_groups_are_not_labelable() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 0\nv 3 3 0\n\
                    g body\nf 1 2 3\ng helper-hair\nf 2 4 5\ng joint-jaw\nf 4 5 6\n";
        assert_eq!(
            labelable_vertices_in(text),
            Some(vec![true, true, true, false, false, false]),
            "vertex 2 is shared with the body and stays"
        );
        assert_eq!(labelable_vertices_in("v 0 0 0\nv 1 0 0\nv 0 1 0\ng head\nf 1 2 3\n"), None);
        // Eyeballs hide the socket behind them; hair does not hide the skin.
        let eyes = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 0\nv 3 3 0\n\
                    g body\nf 1 2 3\ng helper-l-eye\nf 2 4 5\ng helper-hair\nf 6 6 6\n";
        assert_eq!(occluding_vertices_in(eyes), Some(vec![true, true, true, true, true, false]));
        assert_eq!(labelable_vertices_in(eyes), Some(vec![true, true, true, false, false, false]));
    }
    use crate::io::error::Location;

    const P: &str = "t.obj";

    #[test]
    fn keeps_vertex_order_and_resolves_every_reference_form() {
        let text = "# test\nv 0 0 0\nv 1 0 0 1.0\nvt 0 0\nvn 0 0 1\n\
                    g part\nf 2/1/1 1/1/1 -1//1 4/1\nv 0 1 0 0.5 0.5 0.5\nv 1 1 0\n\
                    o other\nf -1 -2 1\n";
        let m = parse_obj(text, Path::new(P)).unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.vertices[1], Point3::new(1.0, 0.0, 0.0));
        assert_eq!(m.vertices[2], Point3::new(0.0, 1.0, 0.0));
        // -1 after two vertices is vertex 1 (0-based); 4 points forward to the last vertex.
        assert_eq!(m.faces[0], vec![1, 0, 1, 3]);
        // A new `o` group does not restart numbering.
        assert_eq!(m.faces[1], vec![3, 2, 0]);
    }

    #[test]
    fn round_trips_through_write() {
        let text = "v 0.1 -2.5 3e-3\nv 1 0 0\nv 0 1 0\nv 1 1 1\nf 4 2 1 3\n";
        let m = parse_obj(text, Path::new(P)).unwrap();
        let mut out = Vec::new();
        write_obj_to(&mut out, &m).unwrap();
        let back = parse_obj(std::str::from_utf8(&out).unwrap(), Path::new(P)).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", Path::new(P)).unwrap_err();
        assert_eq!(e.location, Location::Line(4));
        assert!(e.to_string().contains("t.obj:4"), "{e}");
        let e = parse_obj("v 0 0 0\nf -1 -2 -3\n", Path::new(P)).unwrap_err();
        assert_eq!(e.location, Location::Line(2));
        let e = parse_obj("v 0 0\n", Path::new(P)).unwrap_err();
        assert_eq!(e.location, Location::Line(1));
        let e = parse_obj("v 0 0 x\n", Path::new(P)).unwrap_err();
        assert!(e.message.contains("`x`"));
        let e = parse_obj("v 0 0 0\nv 0 0 0\nv 0 0 0\nf 0 1 2\n", Path::new(P)).unwrap_err();
        assert_eq!(e.location, Location::Line(4));
        let e = parse_obj("v 0 0 0\nv 0 0 0\nf 1 2\n", Path::new(P)).unwrap_err();
        assert_eq!(e.location, Location::Line(3));
    }
}
