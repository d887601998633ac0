//! Histogram of observed dimensions per ground truth of a BOP split:
//! `cargo run --release -p anybox-eval --example observed_dims_stats -- DATASET [SPLIT]`.

use anybox_eval::observed_dims;
use anybox_io::bop::BopDataset;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let root = args
        .next()
        .ok_or("usage: observed_dims_stats DATASET [SPLIT]")?;
    let split = args.next().unwrap_or_else(|| "test".to_string());
    let ds = BopDataset::open(std::path::Path::new(&root), &split)?;
    let mut hist = [0usize; 4];
    let mut hist_visible = [0usize; 4];
    for v in &ds.views {
        for g in &v.gts {
            let mask = v.load_mask_visib(g.gt_index)?;
            let o = observed_dims(&g.pose, &mask, &v.intrinsics);
            hist[o.count as usize] += 1;
            if g.visib_fract >= 0.1 {
                hist_visible[o.count as usize] += 1;
            }
        }
    }
    println!("observed dims 0/1/2/3: all GTs {hist:?}, visib >= 0.1 {hist_visible:?}");
    Ok(())
}
