//! The demo's truth files: `truth.csv` (per frame: phone, W, H, P, pose, cameras, the mouth's
//! articulation) and `errors.csv` (the tracker errors injected).

use super::camera_motion::HeadMotion;
use super::tracker::InjectedError;
use super::visemes::{self, Articulation};
use crate::render::Camera;
use std::fmt::Write as _;

/// One frame's truth row.
pub(super) struct TruthRow {
    pub time: f64,
    pub phone: String,
    pub viseme: String,
    pub w: f64,
    pub h: f64,
    /// P of the foremost mapped upper-lip landmark vertex.
    pub p: f64,
    /// P of the whole upper lip's foremost point: the side view's truth.
    pub p_lip: f64,
    pub w_img: f64,
    pub h_img: f64,
    pub motion: HeadMotion,
    pub front: Camera,
    pub side: Camera,
    pub lip_side_u: f64,
    pub ref_side_u: f64,
    pub articulation: Articulation,
}

const TRUTH_HEADER: &str = "frame,time,phone,viseme,w,h,p,p_lip,w_img,h_img,yaw,pitch,roll,scale,tx,ty,\
side_scale,side_tx,side_ty,lip_side_u,ref_side_u,head_tx_mm,head_ty_mm,head_tz_mm";

pub(super) fn format_truth(rows: &[TruthRow]) -> String {
    let mut s = String::from(TRUTH_HEADER);
    for name in visemes::PARAM_NAMES {
        s.push(',');
        s.push_str(name);
    }
    s.push('\n');
    for (f, r) in rows.iter().enumerate() {
        let (fp, sp) = (&r.front.pose, &r.side.pose);
        let _ = write!(
            s,
            "{f},{:.6},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.6},{:.4},{:.4},{:.6},{:.4},{:.4},{:.3},{:.3},{:.4},{:.4},{:.4}",
            r.time,
            r.phone,
            r.viseme,
            r.w,
            r.h,
            r.p,
            r.p_lip,
            r.w_img,
            r.h_img,
            r.motion.yaw,
            r.motion.pitch,
            r.motion.roll,
            fp.s,
            fp.tx,
            fp.ty,
            sp.s,
            sp.tx,
            sp.ty,
            r.lip_side_u,
            r.ref_side_u,
            r.motion.t.x,
            r.motion.t.y,
            r.motion.t.z
        );
        for v in r.articulation.to_array() {
            let _ = write!(s, ",{v:.5}");
        }
        s.push('\n');
    }
    s
}

pub(super) fn format_errors(errors: &[InjectedError]) -> String {
    let mut s = String::from("frame,kind,point,other,dx,dy\n");
    for e in errors {
        let other = e.other.map_or(String::new(), |o| o.to_string());
        let _ = writeln!(s, "{},{},{},{},{:.3},{:.3}", e.frame, e.kind, e.point, other, e.dx, e.dy);
    }
    s
}
