//! Gray codes and the pattern sequence.

use scan::graycode::{bits_for, gray_decode, gray_encode, Frame, PatternSet};

#[test]
fn gray_round_trip_and_single_bit_steps_on_all_codes_up_to_2_pow_20() {
    for b in 0..(1u32 << 20) {
        let g = gray_encode(b);
        assert_eq!(gray_decode(g), b);
        // Neighbouring codes differ in exactly one bit (the defining property).
        assert_eq!((g ^ gray_encode(b + 1)).count_ones(), 1, "code {b}");
    }
    // And at the top of the range.
    for b in [u32::MAX, u32::MAX - 1, 1 << 31, (1 << 31) - 1] {
        assert_eq!(gray_decode(gray_encode(b)), b);
    }
    // Gray codes of 0..2^n are a permutation of 0..2^n.
    let mut seen = vec![false; 1 << 12];
    for b in 0..(1u32 << 12) {
        let g = gray_encode(b) as usize;
        assert!(!seen[g]);
        seen[g] = true;
    }
}

#[test]
fn bits_are_ceil_log2() {
    assert_eq!(bits_for(1), 0);
    assert_eq!(bits_for(2), 1);
    assert_eq!(bits_for(3), 2);
    assert_eq!(bits_for(768), 10);
    assert_eq!(bits_for(1024), 10);
    assert_eq!(bits_for(1025), 11);
    for n in 2..5000u32 {
        let b = bits_for(n);
        assert!((1u64 << b) >= n as u64 && (1u64 << (b - 1)) < n as u64, "{n}");
    }
}

#[test]
fn sequence_1024x768_is_opencv_order() {
    let p = PatternSet::new(1024, 768, 1).unwrap();
    assert_eq!((p.column_bits(), p.row_bits(), p.len()), (10, 10, 42));
    assert_eq!(p.frame(0), Some(Frame::Column { bit: 9, inverse: false }));
    assert_eq!(p.frame(1), Some(Frame::Column { bit: 9, inverse: true }));
    assert_eq!(p.frame(19), Some(Frame::Column { bit: 0, inverse: true }));
    assert_eq!(p.frame(20), Some(Frame::Row { bit: 9, inverse: false }));
    assert_eq!(p.frame(39), Some(Frame::Row { bit: 0, inverse: true }));
    assert_eq!(p.frame(40), Some(Frame::White));
    assert_eq!(p.frame(41), Some(Frame::Black));
    assert_eq!(p.frame(42), None);
    // Frame 0: the right half lit (the shared captures' README); frame 1 its inverse.
    let f0 = p.image(0).unwrap();
    let f1 = p.image(1).unwrap();
    for x in 0..1024 {
        assert_eq!(f0[x], if x >= 512 { 255 } else { 0 });
        assert_eq!(f0[767 * 1024 + x], f0[x]);
        assert_eq!(f1[x], 255 - f0[x]);
    }
    // Frame 20, the top row bit: the bottom rows 512…767 lit.
    let f20 = p.image(20).unwrap();
    for y in 0..768 {
        assert_eq!(f20[y * 1024 + 7], if y >= 512 { 255 } else { 0 });
    }
    // The finest column bit of the Gray code: period 4, pattern 0,1,1,0.
    let f18 = p.image(18).unwrap();
    assert_eq!(&f18[..8], &[0, 255, 255, 0, 0, 255, 255, 0]);
}

#[test]
fn step_codes_blocks_of_projector_pixels() {
    // 1000 columns at step 3: 334 codes (the last covers one pixel), 9 bits.
    let p = PatternSet::new(1000, 600, 3).unwrap();
    assert_eq!((p.column_codes(), p.row_codes()), (334, 200));
    assert_eq!((p.column_bits(), p.row_bits()), (9, 8));
    assert_eq!(p.len(), 2 * (9 + 8) + 2);
    for x in 0..1000 {
        // Reading the bits back gives the block's code.
        let mut g = 0;
        for bit in (0..9).rev() {
            g = (g << 1) | p.lit(Frame::Column { bit, inverse: false }, x, 0) as u32;
        }
        assert_eq!(gray_decode(g), x / 3);
    }
    assert_eq!(p.column_centre(0), 1.0);
    assert_eq!(p.column_centre(333), 999.0);
    assert_eq!(p.row_centre(199), 598.0);
    assert!(PatternSet::new(0, 5, 1).is_err());
    assert!(PatternSet::new(5, 5, 0).is_err());
}
