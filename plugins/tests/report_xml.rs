//! The report's XML scene style: the three variants, every element, errors with line and column,
//! conversion to TOML that renders the same image, and the reference in docs/report-xml.md.

use raylab::glam::DVec3;
use raylab::load::context::{LoadContext, LoadOptions, Overrides};
use raylab::load::loader::{build, read_file};
use raylab::param::description::SceneDescription;
use raylab::param::value::{Node, Value};
use raylab::render::{RenderOptions, render};
use raylab::{Material, RenderJob, Source};
use raylab_plugins::formats::report_xml::{self, AttrDefault, ELEMENTS, MATERIAL_ATTRS};
use std::path::{Path, PathBuf};

/// The repository's root (the plugins package is one folder down).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// The report-style scenes shipped in scenes/.
fn report_scenes() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    v.sort();
    v
}

fn small() -> LoadOptions {
    LoadOptions { overrides: Overrides { width: Some(64), height: Some(48), ..Overrides::default() }, ..LoadOptions::default() }
}

fn load_path(p: &Path, opts: &LoadOptions) -> RenderJob {
    raylab::load::loader::load_file(&raylab_plugins::registry(), p, opts).unwrap_or_else(|e| panic!("{}", e.report()))
}

/// Parses XML text and builds it; the error when either fails.
fn load_xml(text: &str, opts: &LoadOptions) -> Result<RenderJob, raylab::SceneError> {
    let desc = report_xml::parse(&Source::new("t.xml", text), "t".into())?;
    build(&raylab_plugins::registry(), &desc, &LoadContext::new(Path::new("."), opts))
}

fn error(text: &str) -> raylab::SceneError {
    match load_xml(text, &LoadOptions::default()) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    }
}

/// Asserts that `text` fails at 1-based `line`:`col` with a message containing `needle`.
fn fails_at(text: &str, line: usize, col: usize, needle: &str) {
    let e = error(text);
    assert_eq!(e.where_().as_deref(), Some(format!("t.xml:{line}:{col}").as_str()), "{}", e.report());
    assert!(e.report().contains(needle), "expected \"{needle}\" in:\n{}", e.report());
}

#[test]
fn the_three_styles_load_with_their_cameras_and_sizes() {
    let classic = load_path(&root().join("scenes/report-classic.xml"), &LoadOptions::default());
    let c = &classic.scene.camera;
    assert_eq!((c.screen_width, c.screen_height, c.screen_distance), (500.0, 500.0, 100.0));
    assert_eq!((classic.settings.width, classic.settings.height), (500, 500), "image from the screen's aspect, 500 on the long side");
    assert_eq!(classic.settings.encoding, raylab::Encoding::Linear);

    let later = load_path(&root().join("scenes/report-later.xml"), &LoadOptions::default());
    let c = &later.scene.camera;
    assert_eq!((c.screen_width, c.screen_height, c.screen_distance), (400.0, 300.0, 400.0));
    assert_eq!((later.settings.width, later.settings.height), (640, 480));
    assert_eq!(c.position, DVec3::new(0.0, 70.0, 600.0));
    assert_eq!(later.scene.name, "report later style");

    let minimal = load_path(&root().join("scenes/report-minimal.xml"), &LoadOptions::default());
    let c = &minimal.scene.camera;
    assert_eq!((c.position, c.to, c.up), (DVec3::ZERO, DVec3::NEG_Z, DVec3::Y), "the documented default camera");
    assert_eq!((c.screen_width, c.screen_height, c.screen_distance), (500.0, 500.0, 100.0));
    assert_eq!((minimal.settings.width, minimal.settings.height), (500, 500));
}

#[test]
fn every_element_and_attribute_is_used_by_the_shipped_scenes() {
    let mut used = std::collections::BTreeSet::new();
    for p in report_scenes() {
        let text = std::fs::read_to_string(&p).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        for n in doc.descendants().filter(|n| n.is_element()) {
            let e = n.tag_name().name().to_ascii_lowercase();
            used.insert(format!("<{e}>"));
            for a in n.attributes() {
                used.insert(format!("<{e} {}>", a.name().to_ascii_lowercase()));
            }
        }
    }
    let mut missing = Vec::new();
    for e in ELEMENTS {
        if !used.contains(&format!("<{}>", e.name)) {
            missing.push(format!("<{}>", e.name));
        }
        for a in e.attrs {
            let key = format!("<{} {}>", e.name, a.names[0].to_ascii_lowercase());
            if !used.contains(&key) {
                missing.push(key);
            }
        }
    }
    for a in MATERIAL_ATTRS {
        if !ELEMENTS.iter().filter(|e| e.material).any(|e| used.contains(&format!("<{} {}>", e.name, a.names[0].to_ascii_lowercase()))) {
            missing.push(format!("material attribute {}", a.names[0]));
        }
    }
    assert!(missing.is_empty(), "not covered by scenes/*.xml: {missing:?}");
}

#[test]
fn converted_scenes_render_the_same_image() {
    let dir = std::env::temp_dir().join(format!("raylab-xml-convert-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for xml in report_scenes() {
        let toml = dir.join(xml.file_stem().unwrap()).with_extension("toml");
        let code = raylab::cli::run_with_args(
            raylab_plugins::app(),
            ["raylab".as_ref(), "convert".as_ref(), xml.as_os_str(), "-o".as_ref(), toml.as_os_str()],
        );
        assert_eq!(code, std::process::ExitCode::SUCCESS, "convert {}", xml.display());

        // Same description…
        let reg = raylab_plugins::registry();
        let a = read_file(&reg, &xml, &LoadOptions::default()).unwrap();
        let b = read_file(&reg, &toml, &LoadOptions::default()).unwrap();
        assert!(raylab::param::toml::same_values(&a.root, &b.root), "{} converts to a different table", xml.display());

        // …and the same pixels, bit for bit.
        let opts = small();
        let from_xml = render(&load_path(&xml, &opts), &RenderOptions::default(), &|_, _| {}).unwrap();
        let from_toml = render(&load_path(&toml, &opts), &RenderOptions::default(), &|_, _| {}).unwrap();
        assert!(from_xml.film == from_toml.film, "{}: the converted scene renders differently", xml.display());
        assert!(from_xml.film.pixels.iter().any(|p| p.max_element() > 0.0), "not a black image");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn converting_refuses_a_non_toml_output_and_an_invalid_scene() {
    let dir = std::env::temp_dir().join(format!("raylab-xml-refuse-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.xml");
    std::fs::write(&bad, r#"<scene><geometries><sphere center="0 0 -9" radius="0"/></geometries></scene>"#).unwrap();
    let out = dir.join("bad.toml");
    let run = |args: &[&std::ffi::OsStr]| raylab::cli::run_with_args(raylab_plugins::app(), args.iter().copied());
    assert_ne!(
        run(&["raylab".as_ref(), "convert".as_ref(), bad.as_os_str(), "-o".as_ref(), out.as_os_str()]),
        std::process::ExitCode::SUCCESS
    );
    assert!(!out.exists(), "nothing is written for an invalid scene");
    let classic = root().join("scenes/report-classic.xml");
    let png = dir.join("x.png");
    assert_ne!(
        run(&["raylab".as_ref(), "convert".as_ref(), classic.as_os_str(), "-o".as_ref(), png.as_os_str()]),
        std::process::ExitCode::SUCCESS
    );
    assert!(!png.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn colours_are_0_to_255_and_become_linear_over_255() {
    let job = load_xml(
        r#"<scene background-color="255 0 51" screen-width="500" screen-height="500"><ambient-light color="255 255 255"/>
           <geometries><sphere center="0 0 -200" radius="10" emission="51 102 255" kd="0.5 0.25 1"/></geometries></scene>"#,
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(job.scene.background, DVec3::new(1.0, 0.0, 0.2));
    assert!((job.scene.ambient - DVec3::splat(0.1)).abs().max_element() < 1e-15, "the report's Ka = 0.1");
    let m = &job.scene.objects[0].materials()[0];
    assert_eq!(m.emission, DVec3::new(0.2, 0.4, 1.0));
    assert_eq!(m.kd, DVec3::new(0.5, 0.25, 1.0), "coefficients are taken as they are");
    assert_eq!(m.ks, DVec3::ONE, "the report's default ks");
}

#[test]
fn geometries_default_to_the_report_material_and_the_spec_says_so() {
    let job = load_xml(
        r#"<scene><geometries><sphere center="0 0 -200" radius="10"/><sphere center="0 0 -300" radius="10" kr="0.5"/></geometries></scene>"#,
        &LoadOptions::default(),
    )
    .unwrap();
    let report = Material::report_default();
    assert_eq!(&job.scene.objects[0].materials()[0], &report);
    assert_eq!(&job.scene.objects[1].materials()[0], &Material { kr: DVec3::splat(0.5), ..report });
    for a in MATERIAL_ATTRS {
        assert!(matches!(a.default, AttrDefault::Value(_)), "material attribute {} needs a default", a.names[0]);
    }
}

#[test]
fn spellings_and_case_vary_as_the_style_did() {
    let job = load_xml(
        r#"<Scene BACKGROUND-COLOR="0 0 0" screen-distance="50">
             <IMAGE Screen-Width="300" screen-height="200" nx="30" NY="20"/>
             <camera p0="1 2 3" VTO="0 0 -1" vup="0 1 0"/>
             <geometries><sphere center="0 0 -9" radius="1" nShininess="7" blurring="0.25"/></geometries>
           </Scene>"#,
        &LoadOptions::default(),
    )
    .unwrap();
    let c = &job.scene.camera;
    assert_eq!((c.screen_distance, c.screen_width, c.screen_height), (50.0, 300.0, 200.0));
    assert_eq!(c.position, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!((job.settings.width, job.settings.height), (30, 20));
    let m = &job.scene.objects[0].materials()[0];
    assert_eq!((m.shininess, m.blur), (7.0, 0.25));
}

#[test]
fn missing_sizes_follow_the_other_pairs_aspect() {
    let job = load_xml(r#"<scene screen-width="40" screen-height="10"/>"#, &LoadOptions::default()).unwrap();
    assert_eq!((job.settings.width, job.settings.height), (500, 125));
    let job = load_xml(r#"<scene><image Nx="100" Ny="400"/></scene>"#, &LoadOptions::default()).unwrap();
    assert_eq!((job.scene.camera.screen_width, job.scene.camera.screen_height), (125.0, 500.0));
    assert_eq!((job.settings.width, job.settings.height), (100, 400));
    let job = load_xml("<scene/>", &small()).unwrap();
    assert_eq!((job.settings.width, job.settings.height), (64, 48), "the command line wins");
}

#[test]
fn the_command_line_supplies_or_overrides_the_camera() {
    let src = Source::new("--camera", "[0, 0, 50]");
    let node: Node = raylab::param::toml::parse_toml_value(&src, 0..src.text.len()).unwrap();
    let opts = LoadOptions {
        overrides: Overrides { camera_params: vec![("position".into(), node)], ..Overrides::default() },
        ..LoadOptions::default()
    };
    let job = load_path(&root().join("scenes/report-minimal.xml"), &opts);
    assert_eq!(job.scene.camera.position, DVec3::new(0.0, 0.0, 50.0));
    assert_eq!(job.scene.camera.to, DVec3::NEG_Z, "the rest stays the default");
    let look = Node { value: Value::Array(vec![num(0.0), num(0.0), num(-100.0)]), loc: src_loc() };
    let opts = LoadOptions {
        overrides: Overrides { camera_params: vec![("look_at".into(), look)], ..Overrides::default() },
        ..LoadOptions::default()
    };
    let job = load_path(&root().join("scenes/report-classic.xml"), &opts);
    assert_eq!(job.scene.camera.to, DVec3::NEG_Z, "look_at replaces the report-form camera");

    // Any scene format: a TOML scene without [camera] takes it from the command line.
    let reg = raylab_plugins::registry();
    let toml = "[[object]]\ntype = \"sphere\"\n";
    assert!(raylab::load::loader::load_str(&reg, "t.toml", toml, Path::new("."), &LoadOptions::default()).is_err());
    let job = raylab::load::loader::load_str(&reg, "t.toml", toml, Path::new("."), &opts).unwrap_or_else(|e| panic!("{}", e.report()));
    assert_eq!(job.scene.camera.to, DVec3::NEG_Z);
}

#[test]
fn the_binary_renders_an_xml_scene_with_a_camera_from_the_command_line() {
    let dir = std::env::temp_dir().join(format!("raylab-xml-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("m.png");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", "scenes/report-minimal.xml", "--camera", "position=[0,0,50]", "--width", "10", "--height", "10", "-q", "-o"])
        .arg(&png)
        .current_dir(root())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(png.exists());
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(["render", "scenes/report-minimal.xml", "--camera", "positon=[0,0,50]", "-o"])
        .arg(&png)
        .current_dir(root())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--camera:1:") && err.contains("did you mean `position`"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

fn src_loc() -> raylab::param::error::Loc {
    raylab::param::error::Loc::new(&Source::new("test", "x"), 0..1)
}

fn num(v: f64) -> Node {
    Node { value: Value::Float(v), loc: src_loc() }
}

#[test]
fn errors_name_line_and_column() {
    fails_at("<scene>\n  <geometries>\n    <sphere center=\"0 0 -1\" radius=\"1\">\n  </geometries>\n</scene>", 4, 3, "XML syntax error");
    fails_at("<world/>", 1, 1, "expected <scene> as the root element");
    fails_at("<scene>\n  <geometries><spere/></geometries>\n</scene>", 2, 15, "did you mean <sphere>?");
    fails_at("<scene>\n  <sphere center=\"0 0 0\" radius=\"1\"/>\n</scene>", 2, 3, "<sphere> belongs in <geometries>");
    fails_at("<scene>\n <geometries>\n  <sphere center=\"0 0 -1\" radus=\"1\"/></geometries></scene>", 3, 27, "did you mean `radius`?");
    fails_at("<scene background-color=\"0 0 256\"/>", 1, 30, "colour channels are 0–255");
    fails_at("<scene background-color=\"0 0\"/>", 1, 26, "expected a colour");
    fails_at("<scene><camera vTo=\"0 0 -1\" Vto=\"0 0 1\"/></scene>", 1, 29, "given twice");
    fails_at("<scene><camera/>\n<camera/></scene>", 2, 1, "a second <camera>");
    fails_at("<scene>\n  hello\n</scene>", 2, 3, "unexpected text in <scene>");
    fails_at("<scene><geometries><sphere center=\"0 0 -1\"/></geometries></scene>", 1, 20, "needs attribute `radius`");
    fails_at("<scene><geometries><sphere center=\"0 0 x\" radius=\"1\"/></geometries></scene>", 1, 40, "expected a number, found \"x\"");
    fails_at("<scene><geometries><sphere center=\"0 0 -1\" radius=\"inf\"/></geometries></scene>", 1, 52, "finite");
    fails_at("<scene><image Nx=\"1.5\" Ny=\"2\"/></scene>", 1, 19, "whole number");
    fails_at("<scene><image Nx=\"10\"/></scene>", 1, 8, "gives `Nx` without `Ny`");
    fails_at(
        "<scene screen-width=\"5\" screen-height=\"5\"><image screen-width=\"5\" screen-height=\"5\"/></scene>",
        1,
        8,
        "both <scene> and <image>",
    );
    fails_at(
        "<scene><geometries><sphere center=\"0 0 -1\" radius=\"1\"><x/></sphere></geometries></scene>",
        1,
        55,
        "takes no child elements",
    );
    fails_at("<scene><geometries><polygon vertices=\"0 0 0 1 0 0 1 1\"/></geometries></scene>", 1, 39, "expected points");
    // Errors found by the plugins point into the XML too.
    fails_at("<scene>\n<geometries>\n<sphere center=\"0 0 -1\" radius=\"-2\"/></geometries></scene>", 3, 33, "expected a number > 0");
    fails_at("<scene><camera vTo=\"0 1 0\" vUp=\"0 2 0\"/></scene>", 1, 33, "parallel");
    fails_at("<scene><image Nx=\"100000\" Ny=\"2\"/></scene>", 1, 19, "outside 1..=");
    fails_at("<!DOCTYPE scene [<!ENTITY a \"b\">]><scene/>", 1, 1, "XML syntax error");
}

#[test]
fn entities_in_values_are_read_and_located_at_the_whole_value() {
    let job = load_xml(r#"<scene name="a &amp; b"/>"#, &LoadOptions::default()).unwrap();
    assert_eq!(job.scene.name, "a & b");
    fails_at("<scene background-color=\"0 &#48; x\"/>", 1, 26, "expected a number, found \"x\"");
}

#[test]
fn the_reference_in_the_docs_is_current() {
    let doc = std::fs::read_to_string(root().join("docs/report-xml.md")).unwrap();
    let reference = report_xml::reference();
    assert!(
        doc.contains(&reference),
        "docs/report-xml.md is out of date; paste the output of raylab_plugins::formats::report_xml::reference() into it:\n{reference}"
    );
}

#[test]
fn a_description_reads_back_from_its_toml_exactly() {
    for xml in report_scenes() {
        let a: SceneDescription = read_file(&raylab_plugins::registry(), &xml, &LoadOptions::default()).unwrap();
        let text = raylab::param::toml::to_toml(&a, "header");
        let b = raylab::param::toml::parse_toml(&Source::new("x.toml", text.clone()), "x".into()).unwrap();
        assert!(raylab::param::toml::same_values(&a.root, &b.root), "{}:\n{text}", xml.display());
    }
}

/// The 8-bit colour of pixel (`x`, `y`) of a render of `job`.
fn pixel(job: &RenderJob, x: u32, y: u32) -> [u8; 3] {
    let out = render(job, &RenderOptions::default(), &|_, _| {}).unwrap();
    let rgb = raylab::image::output::to_rgb8(&out.film, job.settings.encoding, None);
    let i = 3 * (y * out.film.width + x) as usize;
    [rgb[i], rgb[i + 1], rgb[i + 2]]
}

/// The course's later dialect has an ambient factor of 1 where `<ambient-light>` gives none, so
/// its first render test shows the shapes in the ambient colour 255 191 191; the report's own
/// style keeps its fixed 0.1; an explicit `Ka` wins in both.
#[test]
fn the_later_dialect_has_ambient_factor_one_and_the_report_keeps_its_tenth() {
    let course = root().join("tests/assets/course/basicRenderTestTwoColors.xml");
    let opts = LoadOptions { overrides: Overrides { width: Some(50), height: Some(50), ..Overrides::default() }, ..LoadOptions::default() };
    let job = load_path(&course, &opts);
    assert_eq!(pixel(&job, 25, 25), [255, 191, 191], "the sphere, in the ambient colour");
    assert_eq!(pixel(&job, 18, 18), [255, 191, 191], "the upper-left triangle");
    assert_eq!(pixel(&job, 32, 18), [75, 127, 90], "the background, where the course has no upper-right triangle");

    let text = std::fs::read_to_string(&course).unwrap();
    let report_style = text
        .replace(
            r#"<scene background-color="75 127 90" screen-distance="100">"#,
            r#"<scene background-color="75 127 90" screen-width="500" screen-height="500" screen-dist="100">"#,
        )
        .replace(r#"<image screen-width="500" screen-height="500" Nx="500" Ny="500"/>"#, "")
        .replace(r#"Vto="0 0 -1" Vup="0 1 0""#, r#"vTo="0 0 -1" vUp="0 1 0""#);
    let report = load_xml(&report_style, &opts).unwrap();
    assert_eq!(pixel(&report, 25, 25), [26, 19, 19], "the report's fixed Ka 0.1");

    // Each marker alone makes the later dialect; no camera and no screen is the course's tests.
    for (marker, later) in [
        (r#"<scene><image Nx="4" Ny="4"/><camera P0="0 0 0" vTo="0 0 -1" vUp="0 1 0"/>"#, true),
        (r#"<scene screen-width="9" screen-height="9"><camera P0="0 0 0" Vto="0 0 -1" vUp="0 1 0"/>"#, true),
        ("<scene>", true),
        (r#"<scene screen-width="9" screen-height="9">"#, false),
        (r#"<scene><camera P0="0 0 0"/>"#, false),
    ] {
        let xml = format!(r#"{marker}<ambient-light color="255 255 255"/></scene>"#);
        let job = load_xml(&xml, &LoadOptions::default()).unwrap();
        assert_eq!(job.scene.ambient, DVec3::splat(if later { 1.0 } else { 0.1 }), "{xml}");
        let explicit = load_xml(&xml.replace("255 255 255\"", "255 255 255\" Ka=\"0.3\""), &LoadOptions::default()).unwrap();
        assert_eq!(explicit.scene.ambient, DVec3::splat(0.3), "{xml}");
    }
}

/// `encoding = "linear-truncated"` writes the course's `(int)` casts: a level and a half
/// truncates where `linear` rounds it up.
#[test]
fn linear_truncated_writes_what_the_course_writes() {
    let course = root().join("tests/assets/course/basicRenderTestTwoColors.xml");
    let text = std::fs::read_to_string(&course).unwrap().replace(r#"color="255 191 191""#, r#"color="255 191 191" Ka="0.5""#);
    let mut opts =
        LoadOptions { overrides: Overrides { width: Some(50), height: Some(50), ..Overrides::default() }, ..LoadOptions::default() };
    assert_eq!(pixel(&load_xml(&text, &opts).unwrap(), 25, 25), [128, 96, 96], "127.5 and 95.5 rounded");
    opts.overrides.encoding = Some(raylab::Encoding::LinearTruncated);
    let job = load_xml(&text, &opts).unwrap();
    assert_eq!(pixel(&job, 25, 25), [127, 95, 95], "127.5 and 95.5 truncated");
    assert_eq!(pixel(&job, 32, 18), [75, 127, 90], "the background's levels stay themselves");
}
