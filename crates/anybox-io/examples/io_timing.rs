//! Times the readers and the BOP writer on the shared `ycbv-boxes` dataset.
//!
//! `cargo run -p anybox-io --release --example io_timing [DATASET_ROOT]`

use std::path::PathBuf;
use std::time::Instant;

use anybox_io::bop::{BopDataset, DatasetWriter, GtRecordOut, ViewRecord};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/ycbv-boxes")
        });
    let t0 = Instant::now();
    let ds = BopDataset::open(&root, "test")?;
    let open_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let mut frames = Vec::new();
    for v in &ds.views {
        frames.push(v.load_frame()?);
    }
    let frames_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let mut masks = Vec::new();
    for v in &ds.views {
        for g in &v.gts {
            masks.push(v.load_mask_visib(g.gt_index)?);
        }
    }
    let masks_s = t0.elapsed().as_secs_f64();
    let tmp = std::env::temp_dir().join(format!("anybox_io_timing_{}", std::process::id()));
    let writer = DatasetWriter::create(&tmp, "test", &ds.models)?;
    let mut records = Vec::new();
    let mut mi = masks.into_iter();
    for (v, f) in ds.views.iter().zip(frames) {
        let gts = v
            .gts
            .iter()
            .map(|g| {
                let m = mi
                    .next()
                    .unwrap_or_else(|| anybox_io::Mask::empty(v.width, v.height));
                GtRecordOut {
                    obj_id: g.obj_id,
                    pose: g.pose,
                    px_count_all: m.count() as u64,
                    px_count_valid: m.count() as u64,
                    visib_fract: g.visib_fract,
                    bbox_obj: m.bbox_xywh(),
                    mask_visib: m,
                }
            })
            .collect();
        records.push(ViewRecord {
            im_id: v.im_id,
            rgb: f
                .rgb
                .unwrap_or_else(|| anybox_io::RgbImage::new(v.width, v.height)),
            depth: f.depth,
            intrinsics: v.intrinsics,
            depth_scale: v.depth_scale,
            gts,
        });
    }
    let t0 = Instant::now();
    writer.write_scene(0, &records)?;
    let write_s = t0.elapsed().as_secs_f64();
    let back = BopDataset::open(&tmp, "test")?;
    assert_eq!(back.n_gt(), ds.n_gt());
    std::fs::remove_dir_all(&tmp)?;
    let n = ds.views.len() as f64;
    println!("views {}, gts {}", ds.views.len(), ds.n_gt());
    println!("open (JSON only)      {:8.2} ms", open_s * 1e3);
    println!(
        "load_frame (RGB+depth) {:7.2} ms / view",
        frames_s * 1e3 / n
    );
    println!(
        "load_mask_visib        {:7.2} ms / mask",
        masks_s * 1e3 / ds.n_gt() as f64
    );
    println!("write_scene            {:7.2} ms / view", write_s * 1e3 / n);
    Ok(())
}
