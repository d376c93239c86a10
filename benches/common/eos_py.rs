//! What the benches that time eos-py share: the Python lines that load eos's model the way
//! eos's own scripts drive it.

/// Python that loads the SFM 3448 shape model with its 6 expression blendshapes as `mm` and
/// the iBUG mapper as `mapper`, from the eos `share` folder named by the variable `share`.
pub const LOAD_MODEL: &str = r#"
m = eos.morphablemodel.load_model(share + '/sfm_shape_3448.bin')
bs = eos.morphablemodel.load_blendshapes(share + '/expression_blendshapes_3448.bin')
mm = eos.morphablemodel.MorphableModel(m.get_shape_model(), bs, color_model=eos.morphablemodel.PcaModel(),
    vertex_definitions=None, texture_coordinates=m.get_texture_coordinates())
mapper = eos.core.LandmarkMapper(share + '/ibug_to_sfm.txt')
"#;
