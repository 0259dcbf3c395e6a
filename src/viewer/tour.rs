//! The guided tour: what the step just run does, in the paper's terms, and what to look at.

use crate::acmm::params::Method;
use crate::session::{Action, Stage, Step};

/// One page of the tour.
#[derive(Clone, Debug, PartialEq)]
pub struct Page {
    /// Section of Xu & Tao, CVPR 2019.
    pub section: &'static str,
    pub title: String,
    pub text: String,
    /// The map that shows the change best.
    pub look_at: &'static str,
}

/// The page for the last step run (`None`: before the first step).
pub fn page(step: Option<&Step>, method: Method) -> Page {
    let Some(step) = step else {
        return Page {
            section: "Sec. 3",
            title: "Before the first step".into(),
            text: format!(
                "{method} estimates a depth and a normal for every pixel of each reference \
                 view by PatchMatch: random planes, then red-black propagation of good planes \
                 to neighbours. Press Step (->) to run one half-iteration."
            ),
            look_at: "image",
        };
    };
    let geometric = matches!(step.stage, Stage::Geometric(_));
    let scale = format!("scale {}/{}", step.level + 1, step.levels);
    if step.stage == Stage::Planar {
        return planar_page(step, &scale);
    }
    match step.action {
        Action::Init if geometric => Page {
            section: "Sec. 5.1",
            title: format!("Geometric consistency: re-scoring the planes ({scale})"),
            text: "Each plane is re-scored with the geometric cost: the photometric cost plus \
                   λ·Δe, where Δe is the forward-backward reprojection error through each \
                   source's current depth map, truncated at δ. Planes that the other views \
                   disagree with now cost more."
                .into(),
            look_at: "reprojection-error",
        },
        Action::Init if step.stage == Stage::Restorer => Page {
            section: "Sec. 5.2",
            title: format!("Detail restorer: C_init ({scale})"),
            text: "Each upsampled plane is scored at this scale: its cost is C_init. The basic \
                   model (ACMH) now starts from these planes (with restorer = random it starts \
                   from random ones instead), and every iteration may replace a plane with a \
                   better one found here, at this scale's full precision."
                .into(),
            look_at: "cost",
        },
        Action::Init if method.is_multiscale() && step.level == 0 && step.levels > 1 => Page {
            section: "Sec. 4.1 and Sec. 1",
            title: format!(
                "Random initialisation at the coarsest of {} scales",
                step.levels
            ),
            text: "Every pixel gets a random plane, as at one scale. The run starts this \
                   small because texture richness is relative: a wall the window cannot tell \
                   apart at full size becomes matchable once the image is small enough for \
                   the window to reach its textured edges. Distance to texture shows, in this \
                   scale's pixels, how far each pixel is from a window that varies by 3 grey \
                   levels; where it is at most the window radius (5), the window sees \
                   texture. With scales_by_texture the run adds scales until that holds for \
                   95% of the pixels."
                .into(),
            look_at: "texture-reach",
        },
        Action::Init => Page {
            section: "Sec. 4.1",
            title: format!("Random initialisation ({scale})"),
            text: "Every pixel gets a random depth in the view's depth range and a random \
                   normal facing the camera. Its cost is the mean of the K best per-source \
                   costs (no view selection yet). The depth map is noise; a few good guesses \
                   are what propagation spreads."
                .into(),
            look_at: "depth",
        },
        Action::Half { iteration, color } => {
            let half = if color == 0 { "red" } else { "black" };
            let (section, what) = if method == Method::Dwta {
                (
                    "Sec. 7.2 (DWTA baseline)",
                    "Each candidate is scored by the mean of its K best source costs (depth \
                     winner-take-all, no view selection).",
                )
            } else {
                (
                    "Sec. 4.2-4.4",
                    "Adaptive checkerboard sampling picks the best plane of each of 8 areas \
                     (4 V shapes, 4 strips) of the other colour. Each candidate is scored by \
                     every source (the cost matrix M); a source joins the view set S_t when \
                     more than n1 costs are below τ(t) and fewer than n2 above τ1. The \
                     candidates' weighted costs decide, then refinement tries 6 perturbed \
                     hypotheses.",
                )
            };
            Page {
                section,
                title: format!("Iteration {iteration}, {half} half ({scale})"),
                text: format!(
                    "{what} Only {half} pixels change.{}{}",
                    if method == Method::Dwta {
                        ""
                    } else {
                        " τ(t) shrinks with the iteration, so view selection gets stricter."
                    },
                    match (geometric, method) {
                        (true, Method::Regions) => {
                            " The cost includes λ·Δe: geometric consistency. With Regions the \
                             prior still weighs (prior_region_hold, on by default): a pixel \
                             with a prior plane picks by the prior-weighted score, as in the \
                             prior-assisted pass, so the views cannot drift off a wall's plane \
                             together where the photometric cost prefers another depth (with \
                             prior_hold_regions_only, only the flat regions' planes hold, and \
                             the prior map shows just those)."
                        }
                        (true, _) => " The cost includes λ·Δe: geometric consistency.",
                        (false, Method::Regions) => {
                            " With Regions the window weighs its samples by the adaptive \
                             bilateral form: Gaussian (Schönberger et al.'s, which the paper \
                             cites), its colour σ the window's own robust spread and never \
                             below σc. A weak wall pixel keeps σc = 3, so an object's samples \
                             across an edge weigh next to nothing and the wall is matched on \
                             its own side, not at the object's depth; a textured window keeps \
                             its texture's samples (kernel in the parameters panel). Click a \
                             wall pixel beside an object: the inspector draws the window's \
                             weights and how many samples' worth of weight the NCC matches on."
                        }
                        _ => "",
                    }
                ),
                look_at: if method == Method::Dwta {
                    "cost"
                } else {
                    "selected-count"
                },
            }
        }
        Action::Median => Page {
            section: "Sec. 4.4",
            title: format!("Median filter ({scale})"),
            text: "A 5x5 median on depth removes isolated outliers that survived propagation."
                .into(),
            look_at: "depth",
        },
        Action::Upsample => Page {
            section: "Sec. 5.1",
            title: format!("Joint bilateral upsampling ({scale})"),
            text: "The coarser scale's planes are upsampled guided by this scale's image: \
                   edges of the image keep the depth edges sharp. The coarse estimate is \
                   reliable in low-texture areas, where this scale's matching is ambiguous."
                .into(),
            look_at: "depth",
        },
        Action::Restore => Page {
            section: "Sec. 5.2",
            title: format!("Detail restorer ({scale})"),
            text: "C_init is the photometric cost of the upsampled plane, C_photo the best \
                   this scale's basic model found. Where C_init - C_photo > ξ the upsampled \
                   plane was an error in the details (thin structures, boundaries) and has \
                   been replaced: the replaced map shows where. In weak texture the \
                   difference stays small and the coarse scale's plane survives: that is \
                   where ACMM gains over ACMH (Compare, depth-error map, the demo's back wall)."
                .into(),
            look_at: "restorer-difference",
        },
        Action::Measure => Page {
            section: "Sec. 5.1",
            title: format!("Reprojection error after the pass ({scale})"),
            text: "The forward-backward reprojection error of the result through each \
                   source, averaged: low where the views agree on the geometry."
                .into(),
            look_at: "reprojection-error",
        },
        // The planar prior's own steps (handled above).
        Action::SupportPoints | Action::Triangulate | Action::PriorPlane => {
            planar_page(step, &scale)
        }
    }
}

/// The planar prior's section: ACMP (Xu & Tao, AAAI 2020) and ACMMP (TPAMI 2022), whose
/// texts are not at hand; mvscope follows the authors' code as ACMP-REFERENCE.md reads it.
const PLANAR_SECTION: &str = "ACMP planar prior";

/// The tour's page for a step of the planar prior's stage.
fn planar_page(step: &Step, scale: &str) -> Page {
    if matches!(step.stage, Stage::Geometric(_)) {
        // Regions' per-region choice (`prior_region_choice`): the restorer's points, kept.
        let (title, what) = match step.action {
            Action::Triangulate => (
                format!("Region choice: the earlier points kept ({scale})"),
                "They are kept with the view, not triangulated yet.",
            ),
            _ => (
                format!("Region choice: the restorer's support points ({scale})"),
                "Each cell's support point is chosen as in the planar prior's stage, from \
                 the planes the detail restorer left, before this geometric pass changes \
                 them.",
            ),
        };
        return Page {
            section: PLANAR_SECTION,
            title,
            text: format!(
                "{what} With 'regions: choose the fit' (Planar prior panel) the prior \
                 stage follows this pass: it triangulates these points as ACMMP would \
                 have, and fits each flat region's planes twice, to these points and to \
                 the points of this pass's result. A region takes the later planes only \
                 where they hold more of its own points. A wall whose points the views \
                 share wrong agrees with itself before the pass; the pass scatters such \
                 points under good cameras, but scatters the right ones under poor \
                 cameras. In the triangulation map a region that took the later fit \
                 draws its points ringed in white."
            ),
            look_at: "support-points",
        };
    }
    let (title, text, look_at) = match step.action {
        Action::SupportPoints => (
            format!("Planar prior: credible support points ({scale})"),
            "The photometric pass before this one left some pixels it is sure of: a cost \
             below the threshold (0.1: NCC above 0.9). The image is cut into 5x5 cells and \
             each cell keeps its lowest-cost pixel if it is that sure. mvscope also asks \
             the other views: only pixels whose depth reprojects into a source and back \
             through that source's depth within 2 px compete (the authors check nothing). \
             In textured areas nearly every cell has one; on a textureless wall almost \
             none, which is the point: the wall's plane will come from the points around \
             it — if those lie on it. The Regions method ranks a cell's sure pixels as \
             HPM-MVS++ does, by cost minus confidence: each source whose depth sends the \
             pixel back within 2 px and 1% of its depth adds up to 1, more the closer it \
             agrees, so the pixel the views agree on best speaks for the cell. Click a \
             pixel: the inspector lists its cell's pixels best first (cost, whether the \
             views agree, confidence, score) and marks the one chosen."
                .to_string(),
            "support-points",
        ),
        Action::Triangulate => (
            format!("Planar prior: triangulation ({scale})"),
            "The support points are joined by a Delaunay triangulation in the image (on \
             the host: a few thousand points), and each triangle's three points, lifted to \
             3-D with their depths, define a plane. Where the scene is piecewise planar, a \
             triangle spanning a textureless region carries that region's plane across it. \
             But one wrong point spoils every triangle it belongs to, and on a textureless \
             wall many are wrong. The Regions method (mvscope's) therefore also cuts the \
             image into flat regions (cells most of whose matching windows are flat: within \
             3 grey levels of their ramp of shading, to which NCC is blind, beyond the \
             image's own sensor noise; joined to their neighbours), takes support points \
             on flat windows of moderate cost too, and fits each region the planes most of \
             its points agree on (RANSAC, within 1% of depth): the coloured cells take their \
             plane's colour, darkened ones (no plane holds most of the points there: not \
             planar; a noisy wall's points that miss its plane evenly on both sides count \
             as held, a curved object's lie on one side) keep their triangles, and the \
             points a plane holds are drawn in its colour. With 'regions on the room's \
             axes' (Planar prior panel) the view's straight lines are found too (drawn in \
             the colour of the direction they point at): a room's walls, floor and \
             furniture meet along three orthogonal directions, so a region's plane is first \
             sought with one of those as its normal, leaving only its offset to the \
             points, which then need not fix a tilt they are too scattered to fix."
                .to_string(),
            "triangulation",
        ),
        Action::PriorPlane => (
            format!("Planar prior: prior depth and normal ({scale})"),
            "Every pixel inside a triangle gets that triangle's plane: its normal, and the \
             depth where the pixel's ray meets it. Pixels outside the points' hull, or whose \
             triangle's depth there leaves the view's range, get no prior (shown as such). \
             Two options from the methods that followed (Planar prior panel): 'past the \
             hull' gives the pixels no triangle covers the plane of their nearest support \
             points (HPM-MVS; on in Regions, whose image borders, seen by no source, then \
             have a plane to keep), 'lock consistent' leaves pixels whose depth the other views \
             confirm without a prior, so they keep their plane (HPM-MVS++). A third, \
             'anchors' (APD-MVS), works where the points fail on walls: a pixel the other \
             views do not confirm looks along 8 directions for the nearest pixels they do, \
             and the plane most of those anchors agree on becomes its prior."
                .to_string(),
            "prior-depth",
        ),
        Action::Init => (
            format!("Prior-assisted pass: restart from the prior ({scale})"),
            "Pixels with a prior whose cost is at least the threshold restart from the prior \
             plane (its depth within ±6%, its normal within a few degrees); the others keep \
             their plane. The 'prior' map shows which pixels restarted."
                .to_string(),
            "prior-effect",
        ),
        _ => (
            format!("Prior-assisted pass, {} ({scale})", step.label_action()),
            "As ACMH's update, but a pixel with a prior chooses the hypothesis of largest \
             score S = exp(−m²/β)·(γ + exp(−Δd²/2σd²)·exp(−Δθ²/2σθ²)) instead of lowest \
             cost m: the prior factor lies in [γ, 1 + γ], so it decides only between \
             hypotheses whose costs are close, which is what textureless areas give. \
             Refinement draws its random hypothesis around the prior plane. The 'prior' \
             map shows where the prior changed the choice. With 'anchors', an anchored \
             pixel's cost m is itself changed: a quarter its own window's, three quarters \
             the mean of its anchors' windows, all warped by the hypothesis's plane, so on a \
             textureless wall the right plane is the one that also matches the textured \
             pixels around it (click a pixel: the inspector lists its anchors and both terms). \
             Regions keeps the prior plane of a pixel whose prior puts its point in no \
             source's image ('keep priors no source sees'; the winner map calls it 'its \
             prior plane'): no source can score that plane, and the cost, which scores it as \
             the worst match, would pull the pixel to any depth some source sees."
                .to_string(),
            "prior-effect",
        ),
    };
    Page {
        section: PLANAR_SECTION,
        title,
        text,
        look_at,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acmm::params::Params;
    use crate::session::build_schedule;

    /// Issue 26, item 11: DWTA's pages said "no view selection" and then "view selection
    /// gets stricter".
    #[test]
    fn only_methods_with_view_selection_say_it_gets_stricter() {
        for method in [Method::Dwta, Method::Acmh] {
            let texts: Vec<String> = build_schedule(method, &Params::default(), &[0], 1)
                .iter()
                .map(|s| page(Some(s), method).text)
                .collect();
            let stricter = texts.iter().any(|t| t.contains("gets stricter"));
            assert_eq!(stricter, method != Method::Dwta, "{method}: {texts:#?}");
        }
    }

    /// Section numbers as the paper's LaTeX source numbers them, with their titles.
    fn paper_sections() -> std::collections::HashMap<String, String> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/paper/acmm-cvpr2019.tex");
        let tex = std::fs::read_to_string(&path).unwrap_or_else(|e| {
            panic!(
                "{}: {e} (the paper must be beside the checkout)",
                path.display()
            )
        });
        let mut out = std::collections::HashMap::new();
        let (mut sec, mut sub) = (0, 0);
        for line in tex.lines() {
            let line = line.trim_start();
            let title = |l: &str| {
                l.split_once('{')
                    .map(|(_, r)| r.split('}').next().unwrap_or("").trim().to_string())
            };
            if line.starts_with("\\section{") {
                sec += 1;
                sub = 0;
                out.insert(format!("{sec}"), title(line).unwrap_or_default());
            } else if line.starts_with("\\subsection{") {
                sub += 1;
                out.insert(format!("{sec}.{sub}"), title(line).unwrap_or_default());
            }
        }
        out
    }

    #[test]
    fn section_labels_are_the_papers() {
        let sections = paper_sections();
        let title = |n: &str| sections.get(n).cloned().unwrap_or_default();
        // What each label must name (the paper's own headings).
        for (number, heading) in [
            ("3", "Overview"),
            ("4.1", "Random Initialization"),
            ("4.2", "Adaptive Checkerboard Sampling"),
            ("4.4", "Refinement"),
            ("5.1", "Geometric Consistency Guidance"),
            ("5.2", "Detail Restorer"),
            ("7.2", "Depth Map Evaluation"),
        ] {
            assert_eq!(title(number), heading, "Sec. {number}");
        }
        let mut steps = build_schedule(Method::Acmm, &Params::default(), &[0, 1], 2);
        steps.extend(build_schedule(Method::Dwta, &Params::default(), &[0], 1));
        let pages: Vec<(Step, Page)> = steps
            .iter()
            .map(|s| {
                let m = if s.levels == 1 {
                    Method::Dwta
                } else {
                    Method::Acmm
                };
                (*s, page(Some(s), m))
            })
            .collect();
        for (step, p) in &pages {
            let number = p.section["Sec. ".len()..]
                .split([' ', '-'])
                .next()
                .unwrap_or("");
            assert!(
                sections.contains_key(number),
                "{}: {}",
                step.label(),
                p.section
            );
            let expected = match (step.stage, step.action) {
                (_, Action::Restore) => "5.2",
                (Stage::Restorer, Action::Init) => "5.2",
                (_, Action::Upsample) => "5.1",
                (Stage::Geometric(_), Action::Init | Action::Measure) => "5.1",
                (_, Action::Median) => "4.4",
                (_, Action::Init) => "4.1",
                (_, Action::Half { .. }) if step.levels == 1 => "7.2",
                (_, Action::Half { .. }) => "4.2",
                _ => number,
            };
            assert_eq!(number, expected, "{}: {}", step.label(), p.section);
        }
    }

    /// The running app (issue 15, item 6), driven through ACMM's and DWTA's schedules with
    /// the tour and the parameter panel open: every "Sec. N" on screen is a section of the
    /// paper, the one its heading's topic is in, and no DWTA step is called ACMH's. Fails
    /// (checked) with the fusion heading citing a "Sec. 5.3", or DWTA's stage labelled
    /// "photometric (ACMH)".
    #[test]
    fn section_labels_on_screen_are_the_papers() {
        use egui_kittest::kittest::{NodeT, Queryable};
        let sections = paper_sections();
        let options = |method| crate::viewer::ViewerOptions {
            demo_size: Some((96, 72)),
            demo_views: Some(3),
            method,
            params: Some(Params {
                iterations: 2,
                coarse_iterations: 2,
                restorer_iterations: 2,
                geometric_iterations: 1,
                ..method.defaults()
            }),
            ..Default::default()
        };
        // (a heading's words, the section a label with them must cite)
        let topics = [
            ("Detail restorer", "5.2"),
            ("Joint bilateral upsampling", "5.1"),
            ("Geometric consistency", "5.1"),
            ("Random initialisation", "4.1"),
            ("Median filter", "4.4"),
            ("View selection (", "4.3"),
            ("Fusion (", "6"),
            ("DWTA baseline", "7.2"),
        ];
        let mut seen = std::collections::BTreeSet::new();
        for method in [Method::Acmm, Method::Dwta] {
            let mut h = crate::viewer::headless_harness(options(method), (1400, 900))
                .expect("a GPU (install mesa-vulkan-drivers)");
            h.state_mut().show_params = true;
            h.step();
            let total = h.state().model.schedule().len();
            let mut done = 0;
            // Before the first step, then points spread over the schedule: every stage kind.
            for target in (0..=12).map(|i| i * total / 12) {
                h.state_mut()
                    .model
                    .run_steps_now(target - done)
                    .expect("the run steps");
                done = target;
                for _ in 0..3 {
                    h.step();
                }
                // Text a user reads: widget labels, and the value of plain text (wrapped
                // text has a node for the whole and one per line).
                let texts: Vec<String> = h
                    .query_all_by(|n| n.label().is_some() || n.value().is_some())
                    .filter_map(|n| {
                        let n = n.accesskit_node();
                        n.label().or_else(|| n.value())
                    })
                    .collect();
                let labels: Vec<String> = texts
                    .iter()
                    .filter(|t| t.contains("Sec. "))
                    .cloned()
                    .collect();
                for label in labels {
                    for cited in label.split("Sec. ").skip(1) {
                        let number: String = cited
                            .chars()
                            .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == '-')
                            .collect();
                        for n in number.trim_end_matches('.').split('-') {
                            assert!(
                                sections.contains_key(n),
                                "{label:?}: no Sec. {n} in the paper"
                            );
                        }
                    }
                    for (words, number) in topics {
                        if label.contains(words) {
                            assert!(
                                label.contains(&format!("Sec. {number}")),
                                "{label:?} should cite Sec. {number} ({})",
                                sections.get(number).cloned().unwrap_or_default()
                            );
                        }
                    }
                    seen.insert(label);
                }
                if method == Method::Dwta {
                    assert!(
                        !texts.iter().any(|t| t.contains("(ACMH)")),
                        "a DWTA step labelled as ACMH's"
                    );
                }
            }
        }
        // The walk reached the multi-scale stages, DWTA's and the parameter panel's headings.
        for cited in ["Sec. 5.1", "Sec. 5.2", "Sec. 4.3", "Sec. 6", "Sec. 7.2"] {
            assert!(
                seen.iter().any(|l| l.contains(cited)),
                "{cited} never shown: {seen:#?}"
            );
        }
    }

    #[test]
    fn every_step_of_an_acmm_schedule_has_a_page_naming_a_map() {
        let s = build_schedule(Method::Acmm, &Params::default(), &[0, 1], 2);
        let mut titles = std::collections::HashSet::new();
        for step in &s {
            let p = page(Some(step), Method::Acmm);
            assert!(p.section.starts_with("Sec."));
            assert!(super::super::maps::MapKind::from_name(p.look_at).is_some());
            titles.insert(p.title);
        }
        // Different steps are explained differently.
        assert!(titles.len() > 6, "{}", titles.len());
        assert!(page(None, Method::Acmh).text.contains("ACMH"));
        // A multi-scale run's coarsest start explains why it starts small and shows the
        // distance to texture; the other scales' starts are the restorer's.
        let first = page(s.first(), Method::Acmm);
        assert_eq!(first.look_at, "texture-reach");
        assert!(
            first.title.contains("coarsest of 2 scales"),
            "{}",
            first.title
        );
        assert!(first.section.contains("Sec. 4.1"));
        let one_scale = build_schedule(Method::Acmh, &Params::default(), &[0, 1], 1);
        assert_eq!(page(one_scale.first(), Method::Acmh).look_at, "depth");
    }
}
