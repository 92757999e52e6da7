//! Bit operations on the 8³ voxel masks of leaves (layout: word x, bit 8y + z) and their 26
//! neighbours, used by the band construction in [`crate::redistance`]: face crossings of a sign
//! mask, the 26-neighbour dilation of a front, and a front padded by one voxel.

/// Bits of an x-word with z = 0.
pub(crate) const Z0: u64 = 0x0101_0101_0101_0101;
/// Bits of an x-word on the y or z faces of a leaf (y = 0, y = 7, z = 0, z = 7).
pub(crate) const FACE_YZ: u64 = 0xFF | (0xFF << 56) | Z0 | Z7;
/// Bits of an x-word with z = 7.
pub(crate) const Z7: u64 = 0x8080_8080_8080_8080;

/// The front bits of a leaf and its 26 neighbours (`front(s)`, slot s = (dx+1)·9 + (dy+1)·3 +
/// dz+1, layout word x, bit 8y + z) on the padded 10³ block around the leaf: entry
/// (x + 1)·10 + y + 1 for x, y in −1..=8 holds bit z + 1 for z in −1..=8.
pub(crate) fn padded_front(front: &impl Fn(usize) -> [u64; 8]) -> [u16; 100] {
    let masks: [[u64; 8]; 27] = std::array::from_fn(front);
    let side = |v: i32| {
        if v < 0 {
            0
        } else if v > 7 {
            2
        } else {
            1
        }
    };
    let mut pad = [0u16; 100];
    for x in -1..=8i32 {
        for y in -1..=8i32 {
            let sl = (side(x) * 9 + side(y) * 3) as usize;
            let (w, sh) = ((x & 7) as usize, 8 * (y & 7) as u32);
            let lo = (masks[sl][w] >> (sh + 7)) & 1;
            let mid = (masks[sl + 1][w] >> sh) & 0xFF;
            let hi = (masks[sl + 2][w] >> sh) & 1;
            pad[((x + 1) * 10 + y + 1) as usize] = (lo | (mid << 1) | (hi << 9)) as u16;
        }
    }
    pad
}

/// The voxels of a leaf-sized block whose inside bit (`m`, layout word x, bit 8y + z) differs
/// from one of its six face neighbours'; `nb(a, s)` gives the mask of the neighbour block one
/// block away along axis a in direction s = ±1.
pub(crate) fn crossings(m: &[u64; 8], nb: &impl Fn(usize, i32) -> [u64; 8]) -> [u64; 8] {
    const Y0: u64 = 0xFF;
    const Y7: u64 = 0xFF << 56;
    let (xm, xp) = (nb(0, -1), nb(0, 1));
    let (ym, yp) = (nb(1, -1), nb(1, 1));
    let (zm, zp) = (nb(2, -1), nb(2, 1));
    let mut out = [0u64; 8];
    for x in 0..8 {
        let w = m[x];
        let lo_x = if x == 0 { xm[7] } else { m[x - 1] };
        let hi_x = if x == 7 { xp[0] } else { m[x + 1] };
        let lo_y = ((w << 8) & !Y0) | (ym[x] >> 56);
        let hi_y = ((w >> 8) & !Y7) | ((yp[x] & Y0) << 56);
        let lo_z = ((w << 1) & !Z0) | ((zm[x] & Z7) >> 7);
        let hi_z = ((w >> 1) & !Z7) | ((zp[x] & Z0) << 7);
        out[x] = (w ^ lo_x) | (w ^ hi_x) | (w ^ lo_y) | (w ^ hi_y) | (w ^ lo_z) | (w ^ hi_z);
    }
    out
}

/// Dilates a leaf's voxel mask by one voxel in all 26 directions, including the contributions of
/// the 26 neighbouring leaves. `mask(s)` gives the mask of the neighbour at slot
/// s = (dx+1)·9 + (dy+1)·3 + (dz+1). Leaf layout: word x, bit 8y + z.
pub(crate) fn dilate26(mask: &impl Fn(usize) -> [u64; 8]) -> [u64; 8] {
    let slot = |dx: i32, dy: i32, dz: i32| ((dx + 1) * 9 + (dy + 1) * 3 + (dz + 1)) as usize;
    // z-dilation of the 9 leaves (dx, dy, 0), taking bits across the z faces
    let mut zd = [[0u64; 8]; 9];
    for dx in -1..=1 {
        for dy in -1..=1 {
            let (c, lo, hi) = (
                mask(slot(dx, dy, 0)),
                mask(slot(dx, dy, -1)),
                mask(slot(dx, dy, 1)),
            );
            for x in 0..8 {
                let w = c[x];
                zd[((dx + 1) * 3 + dy + 1) as usize][x] = w
                    | ((w << 1) & !Z0)
                    | ((w >> 1) & !Z7)
                    | ((lo[x] & Z7) >> 7)
                    | ((hi[x] & Z0) << 7);
            }
        }
    }
    // y-dilation of the 3 leaves (dx, 0, 0)
    let mut yd = [[0u64; 8]; 3];
    for dx in 0..3 {
        let (c, lo, hi) = (zd[dx * 3 + 1], zd[dx * 3], zd[dx * 3 + 2]);
        for x in 0..8 {
            let w = c[x];
            yd[dx][x] = w | (w << 8) | (w >> 8) | (lo[x] >> 56) | (hi[x] << 56);
        }
    }
    // x-dilation of the centre leaf
    let mut out = [0u64; 8];
    for x in 0..8 {
        let prev = if x == 0 { yd[0][7] } else { yd[1][x - 1] };
        let next = if x == 7 { yd[2][0] } else { yd[1][x + 1] };
        out[x] = yd[1][x] | prev | next;
    }
    out
}
