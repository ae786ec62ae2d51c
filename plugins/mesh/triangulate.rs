//! Triangulation of a mesh file's polygons (OBJ faces may have any number of corners).
//!
//! A fan from the first corner is right only for convex polygons; a concave face (an L-shaped
//! floor tile, say) fanned that way gets triangles outside its outline. raylab fans convex faces
//! and clips ears off the others, in the polygon's own plane (Eberly, *Triangulation by Ear
//! Clipping*).

use raylab::glam::{DVec2, DVec3};

/// Most corners a concave face is ear-clipped with (the clipping takes time quadratic in them,
/// so at most this many steps per corner); larger faces are fanned, so a hostile file of huge
/// concave faces loads in time linear in its size.
pub const MAX_EAR_CLIPPED_CORNERS: usize = 256;

/// Most corners of a face whose projection is kept on the stack.
const SMALL_FACE: usize = 8;

/// Triangles covering the simple polygon `points` (corners in order, possibly concave), as
/// indices into `points`, wound like the polygon: exactly `n − 2` of them for `n ≥ 3` corners
/// (none for fewer). A polygon with no area, or with more than [`MAX_EAR_CLIPPED_CORNERS`]
/// corners, gives a fan (the mesh drops degenerate triangles).
pub fn triangulate(points: &[DVec3]) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    triangulate_into(points, &mut out);
    out
}

/// [`triangulate`], the triangles appended to `out` (convex faces allocate nothing).
pub fn triangulate_into(points: &[DVec3], out: &mut Vec<[u32; 3]>) {
    let n = points.len();
    let fan = |out: &mut Vec<[u32; 3]>| out.extend((1..n.saturating_sub(1)).map(|i| [0, i as u32, i as u32 + 1]));
    if n <= 3 {
        return fan(out);
    }
    // Newell's normal; project onto the plane of its two smaller axes, keeping the orientation.
    let mut normal = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        normal += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    if !(normal.length_squared() > 0.0) || !normal.is_finite() {
        return fan(out);
    }
    let axis = normal.abs().max_position();
    let (u, v) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let flip = normal[axis] < 0.0;
    if n > MAX_EAR_CLIPPED_CORNERS {
        return fan(out);
    }
    let project = |q: &DVec3| if flip { DVec2::new(q[v], q[u]) } else { DVec2::new(q[u], q[v]) };
    // The projected corners: on the stack for small faces (the many quads of a mesh file).
    let mut small = [DVec2::ZERO; SMALL_FACE];
    let large: Vec<DVec2>;
    let p: &[DVec2] = if n <= SMALL_FACE {
        for (to, q) in small.iter_mut().zip(points) {
            *to = project(q);
        }
        &small[..n]
    } else {
        large = points.iter().map(project).collect();
        &large
    };
    let cross = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
    if (0..n).all(|i| cross(p[i], p[(i + 1) % n], p[(i + 2) % n]) >= 0.0) {
        return fan(out);
    }
    // Ear clipping over the remaining corners, a doubly linked ring. Whether a corner is an ear
    // changes only for the two neighbours of a clipped one, so each clip re-tests two corners:
    // O(n²) in all.
    let (mut prev, mut next): (Vec<usize>, Vec<usize>) = ((0..n).map(|i| (i + n - 1) % n).collect(), (0..n).map(|i| (i + 1) % n).collect());
    let is_ear = |b: usize, prev: &[usize], next: &[usize]| {
        let (a, c) = (prev[b], next[b]);
        let convex = cross(p[a], p[b], p[c]) > 0.0; // false for NaN
        if !convex {
            return false;
        }
        let mut k = next[c];
        while k != a {
            if inside(p[k], p[a], p[b], p[c]) {
                return false;
            }
            k = next[k];
        }
        true
    };
    let mut ear: Vec<bool> = (0..n).map(|b| is_ear(b, &prev, &next)).collect();
    out.reserve(n - 2);
    let (mut left, mut at) = (n, 0);
    while left > 3 {
        // The next ear going round from the last clip; a self-intersecting outline may have none:
        // then clip any corner rather than loop forever.
        let mut b = at;
        for _ in 0..left {
            if ear[b] {
                break;
            }
            b = next[b];
        }
        let b = if ear[b] { b } else { at };
        let (a, c) = (prev[b], next[b]);
        out.push([a as u32, b as u32, c as u32]);
        next[a] = c;
        prev[c] = a;
        left -= 1;
        ear[a] = is_ear(a, &prev, &next);
        ear[c] = is_ear(c, &prev, &next);
        at = c;
    }
    out.push([prev[at] as u32, at as u32, next[at] as u32]);
}

/// Whether `p` lies in the counter-clockwise triangle `a b c` or on its boundary.
fn inside(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    (b - a).perp_dot(p - a) >= 0.0 && (c - b).perp_dot(p - b) >= 0.0 && (a - c).perp_dot(p - c) >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[DVec3], tris: &[[u32; 3]]) -> f64 {
        tris.iter()
            .map(|t| (points[t[1] as usize] - points[t[0] as usize]).cross(points[t[2] as usize] - points[t[0] as usize]).z * 0.5)
            .sum()
    }

    #[test]
    fn convex_faces_are_fanned_and_concave_ones_stay_inside_their_outline() {
        let square: Vec<DVec3> = [[0, 0], [1, 0], [1, 1], [0, 1]].iter().map(|&[x, y]| DVec3::new(x as f64, y as f64, 0.0)).collect();
        assert_eq!(triangulate(&square), vec![[0, 1, 2], [0, 2, 3]]);
        // An L: a fan from corner 0 would cover the missing square.
        let l: Vec<DVec3> =
            [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]].iter().map(|&[x, y]| DVec3::new(x as f64, y as f64, 0.0)).collect();
        let tris = triangulate(&l);
        assert_eq!(tris.len(), 4);
        assert!((area(&l, &tris) - 3.0).abs() < 1e-12, "every triangle positive and inside: total area 3");
        for t in &tris {
            let c = (l[t[0] as usize] + l[t[1] as usize] + l[t[2] as usize]) / 3.0;
            assert!(!(c.x > 1.0 && c.y > 1.0), "triangle {t:?} lies in the notch");
        }
        // The same L seen from behind (clockwise) keeps its winding.
        let back: Vec<DVec3> = l.iter().rev().copied().collect();
        assert!((area(&back, &triangulate(&back)) + 3.0).abs() < 1e-12);
    }

    /// Every polygon, convex, concave, self-intersecting, flat or not finite, gives `n − 2`
    /// triangles (the OBJ reader places the triangles of deferred faces by this count).
    #[test]
    fn every_polygon_gives_two_triangles_fewer_than_its_corners() {
        let shapes: [&[[f64; 2]]; 6] = [
            &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            &[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]],
            &[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]],
            &[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [4.0, 0.0]],
            &[[0.0, 0.0], [f64::NAN, 0.0], [1.0, 1.0], [0.0, 1.0]],
            &[[0.0, 0.0], [3.0, 0.0], [1.0, 1.0], [3.0, 3.0], [0.0, 3.0], [2.0, 1.5], [-1.0, 1.0]],
        ];
        for shape in shapes {
            let points: Vec<DVec3> = shape.iter().map(|&[x, y]| DVec3::new(x, y, 0.0)).collect();
            assert_eq!(triangulate(&points).len(), points.len() - 2, "{shape:?}");
        }
        let mut out = vec![[9, 9, 9]];
        triangulate_into(&[DVec3::ZERO, DVec3::X, DVec3::Y], &mut out);
        assert_eq!(out, vec![[9, 9, 9], [0, 1, 2]], "appended");
    }

    /// A comb of [`MAX_EAR_CLIPPED_CORNERS`] corners (teeth up from a bar): clipped in O(n²), every
    /// triangle positive and the area exact.
    #[test]
    fn a_large_concave_comb_is_clipped_exactly() {
        let teeth = MAX_EAR_CLIPPED_CORNERS / 4 - 1;
        let mut comb = vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(2.0 * teeth as f64, 0.0, 0.0)];
        for t in (0..teeth).rev() {
            let x = 2.0 * t as f64;
            comb.extend([DVec3::new(x + 2.0, 1.0, 0.0), DVec3::new(x + 1.0, 3.0, 0.0), DVec3::new(x + 1.0, 1.0, 0.0)]);
            comb.push(DVec3::new(x, 1.0, 0.0));
        }
        comb.dedup();
        let tris = triangulate(&comb);
        assert_eq!(tris.len(), comb.len() - 2);
        let expected = 2.0 * teeth as f64 + teeth as f64; // bar, and a triangle of area 1 per tooth
        assert!((area(&comb, &tris) - expected).abs() < 1e-9, "{} vs {expected}", area(&comb, &tris));
        for t in &tris {
            assert!(area(&comb, &[*t]) >= 0.0, "triangle {t:?} is wound backwards");
        }
    }
}
