//! An OBJ control mesh: `sylva check` and one level of `sylva subdivide`.
#![no_main]
use libfuzzer_sys::fuzz_target;
use sylva::refine::{RefineOptions, Scheme, SubdivideOptions};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(obj) = sylva::mesh::obj_read::parse_obj(&text) else { return };
    let _ = sylva::mesh::check::check_mesh(&obj.mesh, &Default::default());
    let options = SubdivideOptions {
        refine: RefineOptions {
            scheme: Scheme::CatmullClark,
            levels: 1,
            max_faces: 100_000,
            ..Default::default()
        },
        ..Default::default()
    };
    let _ = sylva::refine::subdivide(&obj.mesh, &obj.corners, &options);
});
