//! Mutated and hostile files never panic; they give an error (or, for harmless mutations,
//! a valid result).

use anybox_io::camera::read_camera_json;
use anybox_io::image::{read_depth_png, read_mask_png, read_rgb, write_depth_png};
use anybox_io::masks::read_coco_rle_json;
use anybox_io::results::read_results;
use anybox_io::{DepthMap, IoError};
use proptest::prelude::*;

fn valid_depth_png() -> Vec<u8> {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("d.png");
    let mut d = DepthMap::zeros(16, 12);
    for (i, v) in d.depth_mm.iter_mut().enumerate() {
        *v = 300.0 + (i * 37 % 500) as f32;
    }
    write_depth_png(&p, &d, 1.0).unwrap();
    std::fs::read(p).unwrap()
}

/// CRC-32 (IEEE), as PNG chunks use it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn png_header_claiming_a_huge_image_is_rejected_without_allocating() {
    let mut png = valid_depth_png();
    // IHDR data starts at byte 16 (8 signature + 4 length + 4 type): width, height (BE u32).
    png[16..20].copy_from_slice(&60_000u32.to_be_bytes());
    png[20..24].copy_from_slice(&60_000u32.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("huge.png");
    std::fs::write(&p, &png).unwrap();
    let e = read_depth_png(&p, 1.0).unwrap_err();
    assert!(matches!(e, IoError::CorruptImage { .. }), "{e}");
    // Rejected by the decoder's memory limit, not by a checksum error.
    assert!(e.to_string().contains("limit"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn mutated_png_never_panics(edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
                                cut in any::<prop::sample::Index>(), do_cut in any::<bool>()) {
        let mut png = valid_depth_png();
        for (i, b) in edits {
            let k = i.index(png.len());
            png[k] = b;
        }
        if do_cut {
            let k = cut.index(png.len());
            png.truncate(k);
        }
        let t = tempfile::tempdir().unwrap();
        let p = t.path().join("m.png");
        std::fs::write(&p, &png).unwrap();
        if let Ok(d) = read_depth_png(&p, 0.5) {
            prop_assert_eq!(d.depth_mm.len(), (d.width * d.height) as usize);
        }
        let _ = read_rgb(&p);
        let _ = read_mask_png(&p);
    }

    #[test]
    fn mutated_json_never_panics(edits in prop::collection::vec((any::<prop::sample::Index>(), 32u8..127), 1..4)) {
        let t = tempfile::tempdir().unwrap();
        let docs = [
            r#"{"cam_K": [600.0, 0.0, 320.0, 0.0, 600.0, 240.0, 0.0, 0.0, 1.0], "depth_scale": 1.0}"#,
            r#"{"estimates": [{"scene_id": 1, "im_id": 2, "score": 0.5, "R": [1,0,0,0,1,0,0,0,1], "t": [0,0,500], "size": [10,20,30], "time": 0.1, "gt_index": null}]}"#,
            r#"[{"scene_id": 0, "image_id": 0, "category_id": 1, "score": 0.9, "segmentation": {"size": [3, 2], "counts": "0231"}}]"#,
        ];
        for (n, doc) in docs.iter().enumerate() {
            let mut bytes = doc.as_bytes().to_vec();
            for (i, b) in &edits {
                let k = i.index(bytes.len());
                bytes[k] = *b;
            }
            let p = t.path().join(format!("{n}.json"));
            std::fs::write(&p, &bytes).unwrap();
            let _ = read_camera_json(&p);
            let _ = read_results(&p);
            let _ = read_coco_rle_json(&p, Some((2, 3)));
        }
    }
}
