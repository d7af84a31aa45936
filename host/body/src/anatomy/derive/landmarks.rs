//! The landmark rules of the derivation: one rule per landmark, each with
//! the text `docs/anatomy.md` and the data file carry (see the parent
//! module for the derivation body and the frame).
//!
//! Why one long function: every rule reads the same context (positions,
//! parts, sides, the rig's joints) and some rules use landmarks found by
//! earlier ones, in this order; one rule after another, each a few lines, is
//! easier to check against the documentation than a table of closures.

use super::*;

/// Landmark rules. Each entry: name, rule text, chosen kept vertex.
pub(super) fn landmarks(c: &Ctx) -> Result<Vec<DerivedLandmark>, AnatomyError> {
    let mut mids: Vec<(&str, String, u32)> = Vec::new();
    let mut sided: Vec<(&str, String, u32)> = Vec::new();
    let p = |k: u32| c.p[k as usize];
    let x = |k: u32| c.p[k as usize][0];
    let y = |k: u32| c.p[k as usize][1];
    let z = |k: u32| c.p[k as usize][2];
    let body = || c.body_vertices();
    let right_of = move |parts: &'static [u8]| {
        c.body_vertices()
            .filter(move |&k| c.right(k) && c.is_part(k, parts))
    };

    // ---- head, mid-line ----
    let vertex = c.argmax(body().filter(|&k| c.mid(k)), |q| q[2], "vertex")?;
    mids.push(("vertex", "highest mid-plane body vertex".into(), vertex));

    let pronasale = c.argmax(
        body().filter(|&k| c.mid(k) && c.is_part(k, &[HEAD])),
        |q| q[1],
        "pronasale",
    )?;
    mids.push((
        "pronasale",
        "most anterior (max y) mid-plane vertex of the head part".into(),
        pronasale,
    ));

    // Front silhouette of the head on the mid-plane, walked from the nose tip.
    let prof = c.profile(&[HEAD], true);
    let ip = prof
        .iter()
        .position(|&k| k == pronasale)
        .ok_or_else(|| AnatomyError::Rule("pronasale is not on the head profile".into()))?;
    // Walk from index `from` in direction `step` (+1 up, -1 down), keeping the
    // running extreme of s*y; stop when the profile leaves it by `tol` metres.
    let walk = |from: usize, up: bool, s: f64, tol: f64| -> u32 {
        let mut best = prof[from];
        let mut i = from;
        loop {
            let next = if up {
                i.checked_add(1).filter(|&j| j < prof.len())
            } else {
                i.checked_sub(1)
            };
            let Some(j) = next else { return best };
            i = j;
            let k = prof[i];
            if s * y(k) < s * y(best) {
                best = k;
            } else if s * y(k) > s * y(best) + tol {
                return best;
            }
        }
    };
    let sellion = walk(ip, true, 1.0, 0.003);
    mids.push((
        "sellion",
        "walking up the head's mid-plane front silhouette from the pronasale, the deepest (min y) point before the silhouette comes forward again by 3 mm (the nose root)".into(),
        sellion,
    ));
    let is_ = prof.iter().position(|&k| k == sellion).expect("on profile");
    let glabella = walk(is_, true, -1.0, 0.003);
    mids.push((
        "glabella",
        "walking up the silhouette from the sellion, the most anterior point before it recedes by 3 mm (brow ridge between the eyebrows)".into(),
        glabella,
    ));
    let subnasale = walk(ip, false, 1.0, 0.002);
    mids.push((
        "subnasale",
        "walking down the silhouette from the pronasale, the deepest point before it comes forward again by 2 mm (junction of nose and upper lip)".into(),
        subnasale,
    ));
    // Menton: the chin's lowest point, as the support point of the chin in a
    // direction 30 degrees forward of straight down.
    let (sin30, cos30) = (0.5f64, 0.75f64.sqrt());
    let menton = c.argmax(
        prof.iter().copied().filter(|&k| z(k) < z(subnasale) - 0.02),
        |q| sin30 * q[1] - cos30 * q[2],
        "menton",
    )?;
    mids.push((
        "menton",
        "the head's front mid-plane silhouette vertex at least 20 mm below the subnasale that lies furthest in the direction 30 degrees forward of straight down (the bottom of the chin)".into(),
        menton,
    ));
    let g = p(glabella);
    let opisthocranion = c.argmax(
        body().filter(|&k| c.mid(k) && c.is_part(k, &[HEAD])),
        |q| norm(sub(q, g)),
        "opisthocranion",
    )?;
    mids.push((
        "opisthocranion",
        "mid-plane head vertex farthest from the glabella".into(),
        opisthocranion,
    ));

    // ---- head, sided (right = +x) ----
    let tmj = c.joint("jaw", false)?;
    let tragion = c.argmax(
        right_of(&[HEAD]).filter(|&k| {
            let d = sub(p(k), tmj);
            (d[1] * d[1] + d[2] * d[2]).sqrt() < 0.01
        }),
        |q| q[0],
        "tragion",
    )?;
    sided.push((
        "tragion",
        "the jaw bone's head joint J (joint-mouth cube) lies on the mid-plane at the height of the ear canal; among head vertices within 10 mm of the transverse line through J (parallel to x), the most lateral one, which lies on the front of the ear at the tragus".into(),
        tragion,
    ));

    // Eye: right helper sphere.
    let eye_ids: Vec<usize> = c
        .pack
        .groups
        .get("helper-r-eye")
        .ok_or_else(|| AnatomyError::Rule("no helper-r-eye group".into()))?
        .iter()
        .flat_map(|r| r[0]..=r[1])
        .map(|i| i as usize)
        .collect();
    let centre = scale(
        eye_ids.iter().fold([0.0; 3], |s, &i| add(s, c.base[i])),
        1.0 / eye_ids.len() as f64,
    );
    let radius = eye_ids
        .iter()
        .map(|&i| norm(sub(c.base[i], centre)))
        .sum::<f64>()
        / eye_ids.len() as f64;
    // Body triangles near the face, for front-visibility tests.
    let face_tris: Vec<[u32; 3]> = c
        .pack
        .triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&v| c.vpart[v as usize] != NONE))
        .filter(|t| t.iter().any(|&v| norm(sub(p(v), centre)) < 0.12))
        .collect();
    let front_visible = |k: u32| c.visible_from_front(k, &face_tris);
    let lid = |k: u32| norm(sub(p(k), centre)) < radius + 0.002 && front_visible(k);
    let exocanthion = c.argmax(
        right_of(&[HEAD]).filter(|&k| lid(k)),
        |q| q[0],
        "exocanthion",
    )?;
    sided.push((
        "exocanthion",
        "eyelid-margin vertices = head vertices within 2 mm of the right eye helper sphere (centre and mean radius of helper-r-eye) that are visible from the front (a ray towards +y leaves the body); the most lateral one".into(),
        exocanthion,
    ));
    let endocanthion = c.argmax(
        right_of(&[HEAD]).filter(|&k| lid(k)),
        |q| -q[0],
        "endocanthion",
    )?;
    sided.push((
        "endocanthion",
        "the most medial eyelid-margin vertex (as for exocanthion)".into(),
        endocanthion,
    ));
    // Mouth opening rim: front-visible lip vertices with an edge to a lip
    // vertex that is not front-visible (inside the mouth).
    let lips: BTreeMap<u32, bool> = right_of(&[HEAD])
        .filter(|&k| c.vbone[k as usize].starts_with("oris"))
        .map(|k| (k, front_visible(k)))
        .collect();
    let mut rim = std::collections::BTreeSet::new();
    for &[a, b] in &c.edges {
        if let (Some(&va), Some(&vb)) = (lips.get(&a), lips.get(&b)) {
            if va && !vb {
                rim.insert(a);
            } else if vb && !va {
                rim.insert(b);
            }
        }
    }
    let cheilion = c.argmax(rim.iter().copied(), |q| q[0], "cheilion")?;
    sided.push((
        "cheilion",
        "lip vertices = vertices whose dominant bone is a lip bone (oris*); the rim of the mouth opening = lip vertices visible from the front (a ray towards +y leaves the body) joined by an edge to a lip vertex that is not (inside the mouth); the most lateral rim vertex".into(),
        cheilion,
    ));
    let gonion = c.argmax(
        right_of(&[HEAD]).filter(|&k| c.vbone[k as usize] == "jaw"),
        |q| q[0] - q[1] - q[2],
        "gonion",
    )?;
    sided.push((
        "gonion",
        "among vertices whose dominant bone is `jaw`, the one furthest lateral-back-down (max x - y - z): the angle of the mandible".into(),
        gonion,
    ));
    let (ze, yt) = (z(exocanthion), y(tragion));
    let zygion = c.argmax(
        right_of(&[HEAD]).filter(|&k| z(k) <= ze && z(k) >= ze - 0.03 && y(k) > yt + 0.015),
        |q| q[0],
        "zygion",
    )?;
    sided.push((
        "zygion",
        "most lateral head vertex between the exocanthion height and 30 mm below it, at least 15 mm in front of the tragion (excludes the ear)".into(),
        zygion,
    ));

    // ---- neck and torso ----
    // The neck base (ISO 8559-1, ANSUR II's base-of-neck landmarks): where the
    // neck meets the trunk, found as corners of the mid-plane silhouettes
    // between the shoulder joint's height and the neck02 joint's (mid-neck)
    // height. Corners, not rig joints: the neck01 joint sits about 15 mm below
    // the back's corner and the neck/torso part boundary about 20 mm above the
    // front's hollow on the derivation body, and the landmark heights they gave
    // (0.854 and 0.838 of stature) missed ANSUR II's cervicale and
    // suprasternale (0.864 / 0.857 and 0.819 / 0.817, men / women).
    let shoulder = c.joint("upperarm01.R", false)?;
    let neck_mid = c.joint("neck02", false)?;
    let (z_shoulder, z_neck_mid) = (shoulder[2], neck_mid[2]);
    let back = c.profile(&[NECK, TORSO], false);
    let nearest_height = |prof: &[u32], h: f64| -> Result<u32, AnatomyError> {
        prof.iter()
            .copied()
            .min_by(|&a, &b| (z(a) - h).abs().total_cmp(&(z(b) - h).abs()))
            .ok_or_else(|| AnatomyError::Rule("empty mid-plane silhouette".into()))
    };
    let cervicale = {
        let (lo, hi) = (
            nearest_height(&back, z_shoulder)?,
            nearest_height(&back, z_neck_mid)?,
        );
        let (zl, yl, zh, yh) = (z(lo), y(lo), z(hi), y(hi));
        // How far a silhouette vertex lies inside (towards +y, into the body)
        // the chord from `lo` to `hi`.
        let inside = |q: V3| q[1] - (yl + (yh - yl) * (q[2] - zl) / (zh - zl));
        c.argmax(
            back.iter().copied().filter(|&k| z(k) > zl && z(k) < zh),
            inside,
            "cervicale",
        )?
    };
    mids.push((
        "cervicale",
        "back mid-plane silhouette (neck and torso parts) between the heights of the shoulder joint (upperarm01 head) and the neck02 joint: the vertex farthest inside the chord between the silhouette vertices nearest those two heights (the corner where the sloping upper back meets the back of the neck, over C7)".into(),
        cervicale,
    ));
    let front = c.profile(&[NECK, TORSO], true);
    let suprasternale = {
        let span: Vec<u32> = front
            .iter()
            .copied()
            .filter(|&k| z(k) > z_shoulder && z(k) < z_neck_mid)
            .collect();
        let deepest = c.argmax(span.iter().copied(), |q| -q[1], "suprasternale")?;
        c.argmax(
            span.iter().copied().filter(|&k| y(k) <= y(deepest) + 0.002),
            |q| -q[2],
            "suprasternale",
        )?
    };
    mids.push((
        "suprasternale",
        "front mid-plane silhouette (neck and torso parts) between the heights of the shoulder joint (upperarm01 head) and the neck02 joint: its deepest (min y) point is the hollow between the sternum and the throat; of the silhouette vertices within 2 mm of that depth, the lowest (the jugular notch, on the top edge of the sternum)".into(),
        suprasternale,
    ));
    let acromion = c.argmax(
        right_of(&[TORSO, UPPER_ARM]).filter(|&k| {
            let d = sub(p(k), shoulder);
            norm(d) < 0.08 && d[1].abs() < 0.02
        }),
        |q| q[0] + 2.0 * q[2],
        "acromion",
    )?;
    sided.push((
        "acromion",
        "the shoulder's upper-lateral corner: among torso/upper-arm vertices within 80 mm of the shoulder joint (upperarm01 head) and 20 mm of its coronal plane, the one furthest up-and-out (max x + 2 z, a direction 63 degrees above horizontal)".into(),
        acromion,
    ));
    // Neck side: where the side of the neck meets the shoulder (ISO 8559-1's
    // side neck point, ANSUR II's lateral neck / trapezius landmark). The
    // outline's concave corner between the neck and the acromion (the rule
    // until issue 12) sat 95 mm from the mid-plane on the derivation body, on
    // the slope of the shoulder: the neck base through it measured 478 mm
    // against about 400 mm that ANSUR II's means give a body of this size, and
    // the shoulder length from it ran 31 mm short of ANSUR's.
    // Vertices of the neck part none of whose edge neighbours is a torso
    // vertex: the neck proper, one ring above the neck/torso boundary, which
    // on the side lies out on the flare of the shoulder.
    let mut touches_torso = vec![false; c.p.len()];
    for &[a, b] in &c.edges {
        if c.vpart[b as usize] == TORSO {
            touches_torso[a as usize] = true;
        }
        if c.vpart[a as usize] == TORSO {
            touches_torso[b as usize] = true;
        }
    }
    let neck_side = c.argmax(
        right_of(&[NECK])
            .filter(|&k| !touches_torso[k as usize] && (y(k) - neck_mid[1]).abs() < 0.015),
        |q| -q[2],
        "neck_side",
    )?;
    sided.push((
        "neck_side",
        "the lowest neck-part vertex with no torso vertex among its edge neighbours (the neck proper, one ring above the neck/torso boundary) within 15 mm of the coronal plane through the neck02 joint: where the side of the neck meets the shoulder".into(),
        neck_side,
    ));
    let is_arm_boundary = |k: u32| -> bool {
        c.vpart[k as usize] == TORSO
            && c.edges.iter().any(|e| {
                (e[0] == k && c.vpart[e[1] as usize] == UPPER_ARM)
                    || (e[1] == k && c.vpart[e[0] as usize] == UPPER_ARM)
            })
    };
    let apex = c.argmax(
        right_of(&[TORSO]).filter(|&k| is_arm_boundary(k)),
        |q| -q[2],
        "armpit",
    )?;
    let pa = p(apex);
    let near_apex = |k: u32| (x(k) - pa[0]).abs() < 0.01 && (z(k) - pa[2]).abs() < 0.015;
    let axilla_front = c.argmax(
        right_of(&[TORSO, UPPER_ARM]).filter(|&k| near_apex(k)),
        |q| q[1],
        "axilla_front",
    )?;
    sided.push((
        "axilla_front",
        "armpit apex A = lowest torso vertex on the torso/upper-arm boundary; the most anterior torso/upper-arm vertex within 10 mm of A's x and 15 mm of A's height".into(),
        axilla_front,
    ));
    let axilla_back = c.argmax(
        right_of(&[TORSO, UPPER_ARM]).filter(|&k| near_apex(k)),
        |q| -q[1],
        "axilla_back",
    )?;
    sided.push((
        "axilla_back",
        "as axilla_front, the most posterior vertex".into(),
        axilla_back,
    ));

    let thelion = c.argmax(
        right_of(&[TORSO]).filter(|&k| c.vbone[k as usize] == "breast.R"),
        |q| q[1],
        "thelion",
    )?;
    sided.push((
        "thelion",
        "most anterior vertex whose dominant bone is `breast` (bust point)".into(),
        thelion,
    ));
    let front = c.profile(&[TORSO], true);
    let nearest_z = |list: &[u32], zt: f64, what: &str| -> Result<u32, AnatomyError> {
        list.iter()
            .copied()
            .min_by(|&a, &b| {
                (z(a) - zt)
                    .abs()
                    .total_cmp(&(z(b) - zt).abs())
                    .then(a.cmp(&b))
            })
            .ok_or_else(|| AnatomyError::Rule(format!("empty profile for {what}")))
    };
    let mesosternale = nearest_z(&front, z(thelion), "mesosternale")?;
    mids.push((
        "mesosternale",
        "front mid-plane torso silhouette vertex nearest the thelion height".into(),
        mesosternale,
    ));
    let (zlo, zhi) = (c.joint("spine05", false)?[2], c.joint("spine03", false)?[2]);
    let omphalion = {
        // Concavity of a vertex: how far the centroid of its one-ring lies
        // outside it along its (area-weighted) normal; > 0 in a dent.
        let mut ring: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
        for &[a, b] in &c.edges {
            ring.entry(a).or_default().push(b);
            ring.entry(b).or_default().push(a);
        }
        let normal = |k: u32| {
            let mut n = [0.0; 3];
            for t in c.pack.triangles.iter().filter(|t| t.contains(&k)) {
                let [a, b, cc] = t.map(p);
                let (u, w) = (sub(b, a), sub(cc, a));
                n = add(n, cross(u, w));
            }
            unit(n)
        };
        let pelvis_y = c.joint("spine05", false)?[1];
        let cands: Vec<(u32, f64)> = body()
            .filter(|&k| {
                c.is_part(k, &[TORSO])
                    && x(k).abs() < 0.03
                    && y(k) > pelvis_y
                    && z(k) > zlo
                    && z(k) < zhi + 0.03
            })
            .map(|k| {
                let r = &ring[&k];
                let cen = scale(
                    r.iter().fold([0.0; 3], |s, &j| add(s, p(j))),
                    1.0 / r.len() as f64,
                );
                (k, dot(sub(cen, p(k)), normal(k)))
            })
            .collect();
        let top = cands.iter().map(|c| c.1).fold(0.0, f64::max);
        if top <= 0.0 {
            return Err(AnatomyError::Rule("no concave vertex for the navel".into()));
        }
        let navel: Vec<&(u32, f64)> = cands.iter().filter(|c| c.1 > 0.5 * top).collect();
        let wsum: f64 = navel.iter().map(|c| c.1).sum();
        let zc = navel.iter().map(|c| c.1 * z(c.0)).sum::<f64>() / wsum;
        nearest_z(&front, zc, "omphalion")?
    };
    mids.push((
        "omphalion",
        "the navel: concavity of a vertex = distance of its one-ring centroid outside it along its normal; among torso vertices within 30 mm of the mid-plane, in front of the pelvis joint, between the heights of the pelvis joint (spine05 head) and 30 mm above the spine03 head joint, those with more than half the largest concavity form the navel; the front mid-plane silhouette vertex nearest the height of their concavity-weighted centroid".into(),
        omphalion,
    ));
    let waist_back = nearest_z(&back, z(omphalion), "waist_back")?;
    mids.push((
        "waist_back",
        "back mid-plane silhouette vertex nearest the omphalion height".into(),
        waist_back,
    ));
    let crotch = c.argmax(body().filter(|&k| c.mid(k)), |q| -q[2], "crotch")?;
    mids.push(("crotch", "lowest mid-plane body vertex".into(), crotch));
    let buttock_pt = c.argmax(
        body().filter(|&k| {
            c.is_part(k, &[TORSO, THIGH, THIGH + 1])
                && z(k) < z(omphalion)
                && z(k) > z(crotch) - 0.05
        }),
        |q| -q[1],
        "buttock",
    )?;
    let buttock_back = nearest_z(&back, z(buttock_pt), "buttock_back")?;
    mids.push((
        "buttock_back",
        "back mid-plane silhouette vertex nearest the height of the most posterior torso/thigh vertex between 50 mm below the crotch and the omphalion (the buttock point level)".into(),
        buttock_back,
    ));
    let iliocristale = c.argmax(
        right_of(&[TORSO]).filter(|&k| (z(k) - z(omphalion)).abs() < 0.007),
        |q| q[0],
        "iliocristale",
    )?;
    sided.push((
        "iliocristale",
        "most lateral torso vertex within 7 mm of the omphalion height (in ANSUR II the mean iliocristale height is within 16 mm of the omphalion height)".into(),
        iliocristale,
    ));
    let hip = c.joint("upperleg01.R", false)?;
    let trochanterion = c.argmax(
        right_of(&[TORSO, THIGH]).filter(|&k| (z(k) - hip[2]).abs() < 0.007),
        |q| q[0],
        "trochanterion",
    )?;
    sided.push((
        "trochanterion",
        "most lateral torso/thigh vertex within 7 mm of the hip joint height (upperleg01 head)"
            .into(),
        trochanterion,
    ));
    let thigh_top = c.argmax(
        right_of(&[THIGH]).filter(|&k| (z(k) - (z(crotch) - 0.01)).abs() < 0.005),
        |q| -q[0],
        "thigh_top",
    )?;
    sided.push((
        "thigh_top",
        "most medial thigh vertex within 5 mm of the height 10 mm below the crotch".into(),
        thigh_top,
    ));

    // ---- arm ----
    let elbow = c.joint("lowerarm01.R", false)?;
    let wrist = c.joint("lowerarm02.R", true)?;
    let a_up = unit(sub(elbow, shoulder));
    let a_fore = unit(sub(wrist, elbow));
    let basis = |a: V3| {
        let f = perp([0.0, 1.0, 0.0], a);
        let l = perp(perp([1.0, 0.0, 0.0], a), f);
        (f, l)
    };
    let section = |parts: &'static [u8], at: V3, a: V3, h: f64| {
        right_of(parts).filter(move |&k| dot(sub(p(k), at), a).abs() < h)
    };
    let a_elbow = unit(add(a_up, a_fore));
    let (f_el, l_el) = basis(a_elbow);
    let radiale = c.argmax(
        section(&[UPPER_ARM, FOREARM], elbow, a_elbow, 0.008),
        |q| dot(q, l_el),
        "radiale",
    )?;
    sided.push((
        "radiale",
        "most lateral upper-arm/forearm vertex within 8 mm of the plane through the elbow joint (lowerarm01 head) normal to the mean of the upper-arm and forearm axes".into(),
        radiale,
    ));
    let olecranon = c.argmax(
        section(&[UPPER_ARM, FOREARM], elbow, a_elbow, 0.008),
        |q| -dot(q, f_el),
        "olecranon",
    )?;
    sided.push((
        "olecranon",
        "most posterior vertex of the same elbow section".into(),
        olecranon,
    ));
    // The four arm-loop points are chosen by angle around the section's
    // centroid, not by extent along a direction: the section band is sparse
    // on the underside of the A-pose arm, and "furthest towards medial" then
    // picked the same vertex as "furthest towards front".
    // The section is ANSUR's mid upper arm: the plane through the midpoint of
    // the acromion and the radiale, normal to the line between them (the
    // shoulder joint sits inside the shoulder, and a section halfway to the
    // elbow joint still met the armpit, whose underside is torso).
    let a_mid = unit(sub(p(radiale), p(acromion)));
    let mid_upper_arm = scale(add(p(acromion), p(radiale)), 0.5);
    let (f_mid, l_mid) = basis(a_mid);
    let band: Vec<_> = section(&[UPPER_ARM], mid_upper_arm, a_mid, 0.008).collect();
    let centre = {
        let mut sum = [0.0; 3];
        for &k in &band {
            sum = add(sum, p(k));
        }
        scale(sum, 1.0 / band.len().max(1) as f64)
    };
    for (name, dir, desc) in [
        ("biceps_front", f_mid, "anterior"),
        ("biceps_lateral", l_mid, "lateral"),
        ("biceps_back", scale(f_mid, -1.0), "posterior"),
        ("biceps_medial", scale(l_mid, -1.0), "medial"),
    ] {
        let k = c.argmax(
            band.iter().copied(),
            |q| {
                let r = perp(sub(q, centre), a_mid);
                dot(r, dir) / (dot(r, r).sqrt() + 1e-12)
            },
            name,
        )?;
        sided.push((
            name,
            format!("upper-arm vertex within 8 mm of the plane through the midpoint of the acromion and radiale landmarks (normal to the line between them: ANSUR's mid upper arm) whose direction from the section's centroid is closest to {desc} (+y / +x made perpendicular to that line)"),
            k,
        ));
    }
    let thumb = perp(sub(c.joint("finger1-1.R", false)?, wrist), a_fore);
    let stylion = c.argmax(
        section(&[FOREARM, HAND], wrist, a_fore, 0.008),
        |q| dot(q, thumb),
        "stylion",
    )?;
    sided.push((
        "stylion",
        "forearm/hand vertex within 8 mm of the plane through the wrist joint (lowerarm02 tail) normal to the forearm axis, furthest towards the thumb (the thumb's base joint, made perpendicular to the axis)".into(),
        stylion,
    ));
    let ulnar = c.argmax(
        section(&[FOREARM, HAND], wrist, a_fore, 0.008),
        |q| -dot(q, thumb),
        "ulnar_styloid",
    )?;
    sided.push((
        "ulnar_styloid",
        "vertex of the same wrist section furthest away from the thumb".into(),
        ulnar,
    ));
    let tip = c.joint("finger3-3.R", true)?;
    let d_hand = unit(sub(tip, wrist));
    let dactylion = c.argmax(
        right_of(&[HAND]).filter(|&k| c.vbone[k as usize].starts_with("finger3-")),
        |q| dot(q, d_hand),
        "dactylion",
    )?;
    sided.push((
        "dactylion",
        "vertex of the middle finger (dominant bone finger3-*) furthest along the direction from the wrist joint to the finger3-3 tail".into(),
        dactylion,
    ));
    let max_level = |parts: &'static [u8], a: V3, b: V3, t0: f64, t1: f64| -> V3 {
        let n = unit(sub(b, a));
        let (u, w) = (
            perp([0.0, 1.0, 0.0], n),
            perp(perp([1.0, 0.0, 0.0], n), perp([0.0, 1.0, 0.0], n)),
        );
        let mut best = (f64::NEG_INFINITY, a);
        for i in 0..=50 {
            let t = t0 + (t1 - t0) * i as f64 / 50.0;
            let at = add(a, scale(sub(b, a), t));
            let pts = c.cut(parts, true, at, n);
            let per = hull_perimeter(pts.iter().map(|q| [dot(*q, u), dot(*q, w)]).collect());
            if per > best.0 {
                best = (per, at);
            }
        }
        best.1
    };
    let fm = max_level(&[FOREARM], elbow, wrist, 0.1, 0.7);
    let forearm_max = c.argmax(
        section(&[FOREARM], fm, a_fore, 0.008),
        |q| dot(q, basis(a_fore).1),
        "forearm_max",
    )?;
    sided.push((
        "forearm_max",
        "the forearm level of largest girth (convex-hull perimeter of the forearm cut by planes normal to the forearm axis, 51 levels from 10% to 70% of the elbow-to-wrist joint distance); its most lateral vertex within 8 mm of that plane".into(),
        forearm_max,
    ));

    // ---- leg ----
    let knee = c.joint("lowerleg01.R", false)?;
    let ankle = c.joint("foot.R", false)?;
    let knee_slab = |k: u32| (z(k) - knee[2]).abs() < 0.007;
    for (name, f, desc) in [
        ("patella", [0.0, 1.0, 0.0], "most anterior"),
        ("knee_lateral", [1.0, 0.0, 0.0], "most lateral"),
        ("knee_back", [0.0, -1.0, 0.0], "most posterior"),
        ("knee_medial", [-1.0, 0.0, 0.0], "most medial"),
    ] {
        let k = c.argmax(
            right_of(&[THIGH, LOWER_LEG]).filter(|&k| knee_slab(k)),
            |q| dot(q, f),
            name,
        )?;
        sided.push((
            name,
            format!("{desc} thigh/lower-leg vertex within 7 mm of the knee joint height (lowerleg01 head)"),
            k,
        ));
    }
    let tibiale = c.argmax(
        right_of(&[LOWER_LEG]).filter(|&k| z(k) < knee[2] && z(k) > knee[2] - 0.03),
        |q| -q[0],
        "tibiale",
    )?;
    sided.push((
        "tibiale",
        "most medial lower-leg vertex within 10 mm below the knee joint height (top of the tibia, medial)".into(),
        tibiale,
    ));
    let down = [0.0, 0.0, -1.0];
    let cm = max_level(&[LOWER_LEG], knee, [knee[0], knee[1], ankle[2]], 0.1, 0.6);
    let calf_max = c.argmax(
        right_of(&[LOWER_LEG]).filter(|&k| dot(sub(p(k), cm), down).abs() < 0.007),
        |q| -q[1],
        "calf_max",
    )?;
    sided.push((
        "calf_max",
        "the horizontal level of largest lower-leg girth (convex-hull perimeter of horizontal cuts, 51 levels from 10% to 60% of the way from the knee joint down to the ankle joint height); its most posterior vertex within 7 mm".into(),
        calf_max,
    ));
    let ankle_slab = |k: u32| (z(k) - ankle[2]).abs() < 0.01;
    let lateral_malleolus = c.argmax(
        right_of(&[LOWER_LEG, FOOT]).filter(|&k| ankle_slab(k)),
        |q| q[0],
        "lateral_malleolus",
    )?;
    sided.push((
        "lateral_malleolus",
        "most lateral lower-leg/foot vertex within 10 mm of the ankle joint height (foot head)"
            .into(),
        lateral_malleolus,
    ));
    let sphyrion = c.argmax(
        right_of(&[LOWER_LEG, FOOT]).filter(|&k| ankle_slab(k)),
        |q| -q[0],
        "sphyrion",
    )?;
    sided.push((
        "sphyrion",
        "most medial lower-leg/foot vertex within 10 mm of the ankle joint height".into(),
        sphyrion,
    ));
    let pternion = c.argmax(right_of(&[FOOT]), |q| -q[1], "pternion")?;
    sided.push(("pternion", "most posterior foot vertex".into(), pternion));
    let heel_bottom = c.argmax(
        right_of(&[FOOT]).filter(|&k| y(k) < ankle[1]),
        |q| -q[2],
        "heel_bottom",
    )?;
    sided.push((
        "heel_bottom",
        "lowest foot vertex behind the ankle joint (y < ankle y)".into(),
        heel_bottom,
    ));
    let acropodion = c.argmax(right_of(&[FOOT]), |q| q[1], "acropodion")?;
    sided.push((
        "acropodion",
        "most anterior foot vertex (tip of the longest toe)".into(),
        acropodion,
    ));

    // ---- assemble ----
    let mut out = Vec::new();
    let rec = |name: String, k: u32, rule: String| DerivedLandmark {
        name,
        vertex: k,
        base_vertex: c.pack.keep[k as usize],
        rule,
        position: c.p[k as usize],
    };
    for (name, rule, k) in mids {
        if !c.mid(k) {
            return Err(AnatomyError::Rule(format!(
                "{name}: vertex {k} is not on the mid-plane"
            )));
        }
        out.push(rec(name.to_string(), k, rule));
    }
    for (name, rule, k) in sided {
        if !c.right(k) {
            return Err(AnatomyError::Rule(format!(
                "{name}: vertex {k} is not on the right side"
            )));
        }
        out.push(rec(
            format!("{name}_right"),
            k,
            format!("{rule}; right side (+x)"),
        ));
        out.push(rec(
            format!("{name}_left"),
            c.mirror[k as usize],
            format!("mirror partner (hm08.mirror) of {name}_right"),
        ));
    }
    Ok(out)
}
