//! `rodlog import folder|shecar` round trips: what is written is what the dataset holds
//! (pixels, depth, intrinsics, hand poses), read back with rodlog's own reader.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

use std::path::{Path, PathBuf};

use msgs::Msg;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use replay::{McapReader, ReadFilter};

fn pose(i: usize) -> Isometry3<f64> {
    let k = i as f64;
    Isometry3::from_parts(
        Translation3::new(0.1 * k, -0.3 + 0.01 * k, 0.9),
        UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(1.0, k, 0.5)),
            0.1 + 0.2 * k,
        ),
    )
}

/// A 16-bit depth image, millimetres.
type DepthMmImage = image::ImageBuffer<image::Luma<u16>, Vec<u16>>;

/// A 3-view folder dataset with 40x30 colour images and 16-bit depth on views 0 and 2.
fn make_folder(dir: &Path) -> (Vec<image::RgbImage>, Vec<Option<DepthMmImage>>) {
    std::fs::create_dir_all(dir.join("images")).expect("mkdir");
    std::fs::create_dir_all(dir.join("depth")).expect("mkdir");
    std::fs::write(
        dir.join("camera.yaml"),
        "# test camera\nfx: 50.5\nfy: 51.25\ncx: 19.5\ncy: 14.75\nk1: -0.05\nk2: 0.01\np1: 0.001\np2: -0.002\nk3: 0.0005\nwidth: 40\nheight: 30\n",
    )
    .expect("camera.yaml");
    let mut tum = String::new();
    let mut colors = Vec::new();
    let mut depths = Vec::new();
    for i in 0..3usize {
        let img = image::RgbImage::from_fn(40, 30, |x, y| {
            image::Rgb([(x * 6) as u8, (y * 8 + i as u32) as u8, ((x ^ y) * 3) as u8])
        });
        img.save(dir.join(format!("images/{i:06}.png")))
            .expect("save image");
        colors.push(img);
        if i != 1 {
            let d = DepthMmImage::from_fn(40, 30, |x, y| {
                image::Luma([if x == 0 {
                    0
                } else {
                    300 + (x * 7 + y * 3) as u16 + i as u16
                }])
            });
            d.save(dir.join(format!("depth/{i:06}.png")))
                .expect("save depth");
            depths.push(Some(d));
        } else {
            depths.push(None);
        }
        let p = pose(i);
        let t = p.translation.vector;
        let q = p.rotation.coords;
        tum.push_str(&format!(
            "{i} {} {} {} {} {} {} {}\n",
            t.x, t.y, t.z, q.x, q.y, q.z, q.w
        ));
    }
    std::fs::write(dir.join("hand_poses.txt"), tum).expect("poses");
    (colors, depths)
}

fn read_all(path: &Path) -> Vec<(String, Msg)> {
    let mut reader = McapReader::open(path).expect("open recording");
    reader
        .read_all(&ReadFilter::all())
        .expect("read")
        .iter()
        .map(|m| (m.topic().to_owned(), m.decode().expect("decode")))
        .collect()
}

#[test]
fn folder_import_round_trips_pixels_depth_intrinsics_and_poses() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path().join("ds");
    let (colors, depths) = make_folder(&dir);
    let out: PathBuf = tmp.path().join("ds.mcap");
    let run = rodlog(&[
        "import",
        "folder",
        &dir.display().to_string(),
        "-o",
        &out.display().to_string(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    let messages = read_all(&out);
    let infos: Vec<_> = messages
        .iter()
        .filter_map(|(_, m)| m.get::<msgs::sensor_msgs::CameraInfo>())
        .collect();
    assert_eq!(infos.len(), 1);
    assert_eq!(
        infos[0].k,
        [50.5, 0.0, 19.5, 0.0, 51.25, 14.75, 0.0, 0.0, 1.0]
    );
    assert_eq!(infos[0].d, vec![-0.05, 0.01, 0.001, -0.002, 0.0005]);
    assert_eq!(infos[0].distortion_model, "plumb_bob");

    let images: Vec<_> = messages
        .iter()
        .filter(|(t, _)| t == "/camera/color/image_raw")
        .filter_map(|(_, m)| m.get::<msgs::sensor_msgs::Image>())
        .collect();
    assert_eq!(images.len(), 3);
    for (img, want) in images.iter().zip(&colors) {
        assert_eq!(img.encoding, "rgb8");
        assert_eq!((img.width, img.height, img.step), (40, 30, 120));
        assert_eq!(&img.data, want.as_raw());
    }
    let depth_msgs: Vec<_> = messages
        .iter()
        .filter(|(t, _)| t == "/camera/depth/image_raw")
        .filter_map(|(_, m)| m.get::<msgs::sensor_msgs::Image>())
        .collect();
    assert_eq!(depth_msgs.len(), 2);
    for (d, want) in depth_msgs.iter().zip(depths.iter().flatten()) {
        assert_eq!(d.encoding, "16UC1");
        let mm: Vec<u16> = d
            .data
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect();
        assert_eq!(&mm, want.as_raw());
    }
    // Depth shares its colour image's stamp (view 2 -> 3 s).
    assert_eq!(depth_msgs[1].header.stamp, images[2].header.stamp);

    let tfs: Vec<_> = messages
        .iter()
        .filter_map(|(_, m)| m.get::<msgs::tf2_msgs::TfMessage>())
        .collect();
    assert_eq!(tfs.len(), 3);
    for (i, tf) in tfs.iter().enumerate() {
        let t = &tf.transforms[0];
        assert_eq!(
            (t.header.frame_id.as_str(), t.child_frame_id.as_str()),
            ("base_link", "tool0")
        );
        assert_eq!(t.header.stamp, images[i].header.stamp);
        let got = robot::conversions::isometry_from_msg(&t.transform).expect("finite");
        let err = (got.to_homogeneous() - pose(i).to_homogeneous())
            .abs()
            .max();
        assert!(err < 1e-12, "view {i}: pose error {err:e}");
    }
}

#[test]
fn folder_import_refuses_inconsistent_datasets_clearly() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path().join("ds");
    make_folder(&dir);
    let out = tmp.path().join("x.mcap").display().to_string();
    let d = dir.display().to_string();

    std::fs::write(
        dir.join("camera.yaml"),
        "fx: 50\nfy: 50\ncx: 20\nwidth: 40\nheight: 30\n",
    )
    .expect("write");
    let run = rodlog(&["import", "folder", &d, "-o", &out]);
    assert!(!run.status.success());
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("missing `cy`"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    std::fs::write(
        dir.join("camera.yaml"),
        "fx: 50\nfy: 50\ncx: 20\ncy: 15\nwidth: 64\nheight: 48\n",
    )
    .expect("write");
    let run = rodlog(&["import", "folder", &d, "-o", &out]);
    assert!(!run.status.success());
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("intrinsics are for 64x48"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    std::fs::write(
        dir.join("camera.yaml"),
        "fx: 50\nfy: 50\ncx: 20\ncy: 15\nwidth: 40\nheight: 30\n",
    )
    .expect("write");
    std::fs::remove_file(dir.join("images/000001.png")).expect("rm");
    let run = rodlog(&["import", "folder", &d, "-o", &out]);
    assert!(!run.status.success());
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("no image"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn shecar_import_has_18_views_with_scaled_intrinsics() {
    let Some(data) = testkit::shared_data("shecar", "shecar import") else {
        return;
    };
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("shecar.mcap");
    let run = rodlog(&[
        "import",
        "shecar",
        &data.display().to_string(),
        "-o",
        &out.display().to_string(),
        "--scale",
        "0.25",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let messages = read_all(&out);
    let images: Vec<_> = messages
        .iter()
        .filter_map(|(_, m)| m.get::<msgs::sensor_msgs::Image>())
        .collect();
    assert_eq!(images.len(), 18);
    assert_eq!((images[0].width, images[0].height), (816, 459));
    let info = messages
        .iter()
        .find_map(|(_, m)| m.get::<msgs::sensor_msgs::CameraInfo>())
        .expect("camera info");
    // f = 2439.50225 px at 3264 px wide -> x0.25.
    assert!((info.k[0] - 2439.50225 * 0.25).abs() < 1e-9);
    assert!((info.k[2] - ((1615.55613 + 0.5) * 0.25 - 0.5)).abs() < 1e-9);
    assert_eq!(&info.d[..2], &[0.18436, -0.32515]);
    let tfs = messages.iter().filter(|(t, _)| t == "/tf").count();
    assert_eq!(tfs, 18);
}
