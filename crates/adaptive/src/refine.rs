//! The CPU side of adaptive light-source sampling (Schwärzler, section 3.3): where samples sit
//! on the light, which maps are compared, how a cell splits and what each sample weighs. No GPU
//! here, so all of it is unit-tested.
//!
//! Sample positions are integer keys on a grid of `resolution` steps per light axis
//! (`resolution = 2^(max_depth + 2)`), so a sample reached by two cells is one map.

use std::collections::{BTreeMap, BTreeSet};

use softshadow_core::glam::Vec2;

softshadow_core::param_choice! {
    /// Where a cell's samples sit.
    pub enum Start {
        /// At the cell's corners (ends of the segment for a linear light), shared with its
        /// neighbours: the paper's scheme (sections 3.3.1 and 3.3.5). A full split to depth d gives
        /// a (2^d + 1)^2 grid that includes the light's edges.
        Corners = "corners",
        /// At the centres of the cell's quadrants (halves for a linear light): a cell-centred
        /// variant whose full split to depth d is the 2^(d+1) x 2^(d+1) grid of strata centres,
        /// i.e. the fixed-grid accumulation (`reference` without jitter). A split does not reuse
        /// the parent's maps.
        Centre = "centre",
    }
}

softshadow_core::param_choice! {
    /// What each map weighs in the final image (the weights always sum to 1).
    pub enum Weighting {
        /// The paper's eq. 5 (segment) / eq. 6 (rectangle) with d = the deepest leaf that has
        /// the sample as a corner, normalised (section 3.3.6).
        Paper = "paper",
        /// Each leaf cell's length (area) shared equally by its 2 ends (4 corners): the
        /// trapezoid rule over the leaves. Unlike eq. 6 it gives the light's edge and corner
        /// samples the half and quarter cell they stand for (not in the paper).
        Area = "area",
        /// Every map weighs 1/n.
        Off = "off",
    }
}

/// How many axes the light has: a segment (section 3.3, eq. 5) or a rectangle (3.3.5, eq. 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Width 0 and height 0: every sample is the centre; treated as a segment along u.
    /// Height 0: a segment along u.
    SegmentU,
    /// Width 0, height > 0: a segment along v.
    SegmentV,
    /// Width and height > 0.
    Rectangle,
}

impl Shape {
    /// The shape of a light of half extents `half`.
    pub fn of(half: Vec2) -> Self {
        if half.y == 0.0 {
            Shape::SegmentU
        } else if half.x == 0.0 {
            Shape::SegmentV
        } else {
            Shape::Rectangle
        }
    }

    /// The light is a segment (one of its extents is 0).
    pub fn is_segment(self) -> bool {
        self != Shape::Rectangle
    }
}

/// A sample position in grid steps (`y` is 0 on a segment).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SampleKey {
    /// Grid step along the light's width.
    pub x: u32,
    /// Grid step along the light's height.
    pub y: u32,
}

/// A quadtree cell (an interval of a binary tree on a segment): `2^depth` cells per axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cell {
    /// Subdivision level (0 = the whole light).
    pub depth: u32,
    /// Column at this level.
    pub i: u32,
    /// Row at this level.
    pub j: u32,
}

impl Cell {
    /// The whole light.
    pub const ROOT: Cell = Cell {
        depth: 0,
        i: 0,
        j: 0,
    };
}

/// The sampling layout of one frame: light shape, start scheme and grid resolution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    /// Rectangle or segment.
    pub shape: Shape,
    /// Where a cell's samples are.
    pub start: Start,
    /// Deepest subdivision level.
    pub max_depth: u32,
}

impl Layout {
    /// Grid steps per light axis: enough for quadrant centres of the deepest cells.
    pub fn resolution(&self) -> u32 {
        1 << (self.max_depth + 2)
    }

    fn cell_size(&self, cell: Cell) -> u32 {
        self.resolution() >> cell.depth
    }

    /// The samples of `cell`: 2 on a segment, 4 on a rectangle (order: (0,0), (1,0), (0,1),
    /// (1,1) in cell-local corners or quadrants).
    pub fn samples(&self, cell: Cell) -> Vec<SampleKey> {
        let s = self.cell_size(cell);
        let (x0, y0) = (cell.i * s, cell.j * s);
        let (lo, hi) = match self.start {
            Start::Corners => (0, s),
            Start::Centre => (s / 4, 3 * s / 4),
        };
        if self.shape.is_segment() {
            vec![
                SampleKey { x: x0 + lo, y: 0 },
                SampleKey { x: x0 + hi, y: 0 },
            ]
        } else {
            vec![
                SampleKey {
                    x: x0 + lo,
                    y: y0 + lo,
                },
                SampleKey {
                    x: x0 + hi,
                    y: y0 + lo,
                },
                SampleKey {
                    x: x0 + lo,
                    y: y0 + hi,
                },
                SampleKey {
                    x: x0 + hi,
                    y: y0 + hi,
                },
            ]
        }
    }

    /// The compared pairs of `cell`: its two ends on a segment (section 3.3.3), the two
    /// diagonals on a rectangle (section 3.3.5).
    pub fn pairs(&self, cell: Cell) -> Vec<(SampleKey, SampleKey)> {
        let s = self.samples(cell);
        if self.shape.is_segment() {
            vec![(s[0], s[1])]
        } else {
            vec![(s[0], s[3]), (s[1], s[2])]
        }
    }

    /// The cells a split of `cell` makes: 2 halves on a segment, 4 quadrants on a rectangle.
    pub fn children(&self, cell: Cell) -> Vec<Cell> {
        let depth = cell.depth + 1;
        let (i, j) = (cell.i * 2, cell.j * 2);
        if self.shape.is_segment() {
            vec![
                Cell { depth, i, j: 0 },
                Cell {
                    depth,
                    i: i + 1,
                    j: 0,
                },
            ]
        } else {
            vec![
                Cell { depth, i, j },
                Cell { depth, i: i + 1, j },
                Cell { depth, i, j: j + 1 },
                Cell {
                    depth,
                    i: i + 1,
                    j: j + 1,
                },
            ]
        }
    }

    /// Light-space position `(u, v)` of a sample on the light `[-half.x, half.x] x [-half.y, half.y]`.
    pub fn position(&self, key: SampleKey, half: Vec2) -> Vec2 {
        let r = self.resolution() as f32;
        let along = |k: u32, h: f32| -h + 2.0 * h * (k as f32 / r);
        match self.shape {
            Shape::SegmentU => Vec2::new(along(key.x, half.x), 0.0),
            Shape::SegmentV => Vec2::new(0.0, along(key.x, half.y)),
            Shape::Rectangle => Vec2::new(along(key.x, half.x), along(key.y, half.y)),
        }
    }

    /// The samples the final image uses and their weights, summing to 1 (see [`Weighting`]). For
    /// `start = centre` both `paper` and `area` give each sample its share of its leaf's area
    /// (1 / 2^(d+1) or 1 / 4^(d+1), already summing to 1), the centre scheme's analogue of eq. 5
    /// / 6.
    pub fn weights(&self, leaves: &BTreeSet<Cell>, weighting: Weighting) -> Vec<(SampleKey, f64)> {
        // Per sample: the deepest leaf that has it as a corner (eq. 5 / 6), and the trapezoid
        // weight summed over the leaves that have it.
        let mut depth: BTreeMap<SampleKey, u32> = BTreeMap::new();
        let mut area: BTreeMap<SampleKey, f64> = BTreeMap::new();
        let corners = if self.shape.is_segment() { 2 } else { 4 };
        for leaf in leaves {
            let leaf_share = if self.shape.is_segment() {
                0.5f64.powi(leaf.depth as i32)
            } else {
                0.25f64.powi(leaf.depth as i32)
            } / f64::from(corners);
            for key in self.samples(*leaf) {
                let d = depth.entry(key).or_insert(leaf.depth);
                *d = (*d).max(leaf.depth);
                *area.entry(key).or_insert(0.0) += leaf_share;
            }
        }
        let raw: Vec<(SampleKey, f64)> = depth
            .into_iter()
            .map(|(key, d)| {
                let per_axis = match self.start {
                    Start::Corners => 2f64.powi(d as i32) + 1.0,
                    Start::Centre => 2f64.powi(d as i32 + 1),
                };
                let paper = if self.shape.is_segment() {
                    1.0 / per_axis
                } else {
                    1.0 / (per_axis * per_axis)
                };
                let w = match (weighting, self.start) {
                    (Weighting::Off, _) => 1.0,
                    (Weighting::Paper, _) | (Weighting::Area, Start::Centre) => paper,
                    (Weighting::Area, Start::Corners) => area[&key],
                };
                (key, w)
            })
            .collect();
        let total: f64 = raw.iter().map(|(_, w)| w).sum();
        if total <= 0.0 || raw.is_empty() {
            return raw;
        }
        raw.into_iter().map(|(k, w)| (k, w / total)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn full_split(layout: &Layout, depth: u32) -> BTreeSet<Cell> {
        let mut leaves = BTreeSet::from([Cell::ROOT]);
        for _ in 0..depth {
            leaves = leaves.iter().flat_map(|c| layout.children(*c)).collect();
        }
        leaves
    }

    #[test]
    fn a_full_split_gives_the_regular_grids_with_equal_weights() {
        for (start, shape, depth, expected) in [
            (Start::Corners, Shape::Rectangle, 2, 25),
            (Start::Corners, Shape::SegmentU, 3, 9),
            (Start::Centre, Shape::Rectangle, 2, 64),
            (Start::Centre, Shape::SegmentV, 3, 16),
        ] {
            let layout = Layout {
                shape,
                start,
                max_depth: 4,
            };
            let weights = layout.weights(&full_split(&layout, depth), Weighting::Paper);
            assert_eq!(weights.len(), expected, "{start:?} {shape:?}");
            for (_, w) in &weights {
                assert!((w - 1.0 / expected as f64).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn centre_samples_are_the_strata_centres() {
        let layout = Layout {
            shape: Shape::Rectangle,
            start: Start::Centre,
            max_depth: 3,
        };
        let half = Vec2::new(1.0, 0.5);
        let mut positions: Vec<(i32, i32)> = full_split(&layout, 1)
            .iter()
            .flat_map(|c| layout.samples(*c))
            .map(|k| layout.position(k, half))
            .map(|p| ((p.x * 8.0).round() as i32, (p.y * 16.0).round() as i32))
            .collect();
        positions.sort();
        // 4 x 4 strata centres at +-1/8, +-3/8, ... of the width (times 8) and height (times 16).
        let expected: Vec<(i32, i32)> = {
            let mut v = Vec::new();
            for x in [-6, -2, 2, 6] {
                for y in [-6, -2, 2, 6] {
                    v.push((x, y));
                }
            }
            v.sort();
            v
        };
        assert_eq!(positions, expected);
    }

    #[test]
    fn deeper_corners_weigh_less_and_the_weights_sum_to_one() {
        let layout = Layout {
            shape: Shape::Rectangle,
            start: Start::Corners,
            max_depth: 4,
        };
        // Split the root, then only its first quadrant.
        let mut leaves: BTreeSet<Cell> = layout.children(Cell::ROOT).into_iter().collect();
        let first = Cell {
            depth: 1,
            i: 0,
            j: 0,
        };
        leaves.remove(&first);
        leaves.extend(layout.children(first));
        let weights = layout.weights(&leaves, Weighting::Paper);
        // 9 corners of depth 1 plus 5 new ones (4 edge midpoints of the quadrant and its centre,
        // two of which already existed): 9 + 5 = 14.
        assert_eq!(weights.len(), 14);
        let sum: f64 = weights.iter().map(|(_, w)| w).sum();
        assert!((sum - 1.0).abs() < 1e-12);
        let far_corner = weights
            .iter()
            .find(|(k, _)| k.x == 64 && k.y == 64)
            .unwrap()
            .1;
        let deep = weights
            .iter()
            .find(|(k, _)| k.x == 16 && k.y == 16)
            .unwrap()
            .1;
        // eq. 6: 1/(2^1+1)^2 against 1/(2^2+1)^2 before normalising.
        assert!((far_corner / deep - 25.0 / 9.0).abs() < 1e-9);
    }

    #[test]
    fn area_weights_are_the_trapezoid_rule_over_the_leaves() {
        let layout = Layout {
            shape: Shape::Rectangle,
            start: Start::Corners,
            max_depth: 3,
        };
        // A full split to depth 1: a 3 x 3 grid; trapezoid weights 1/16 (corners), 1/8 (edge
        // midpoints), 1/4 (centre).
        let weights = layout.weights(&full_split(&layout, 1), Weighting::Area);
        assert_eq!(weights.len(), 9);
        let r = layout.resolution();
        for (key, w) in &weights {
            let on_edge = |k: u32| k == 0 || k == r;
            let expected = match (on_edge(key.x), on_edge(key.y)) {
                (true, true) => 1.0 / 16.0,
                (true, false) | (false, true) => 1.0 / 8.0,
                (false, false) => 1.0 / 4.0,
            };
            assert!((w - expected).abs() < 1e-12, "{key:?}: {w} vs {expected}");
        }
        // A segment split to depth 2: ends 1/8, inner points 1/4.
        let segment = Layout {
            shape: Shape::SegmentU,
            ..layout
        };
        let weights = segment.weights(&full_split(&segment, 2), Weighting::Area);
        let got: Vec<f64> = weights.iter().map(|(_, w)| *w).collect();
        let expected = [0.125, 0.25, 0.25, 0.25, 0.125];
        assert_eq!(got.len(), 5);
        for (g, e) in got.iter().zip(expected) {
            assert!((g - e).abs() < 1e-12, "{got:?}");
        }
        // Paper weights on the same grid are equal (eq. 6 with one depth): the edge bias.
        let paper = layout.weights(&full_split(&layout, 1), Weighting::Paper);
        assert!(paper.iter().all(|(_, w)| (w - 1.0 / 9.0).abs() < 1e-12));
    }
}
