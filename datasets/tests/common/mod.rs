//! Fixtures shared by the bag tests (`bags.rs`, `cases.rs`): a scratch folder, files
//! written into it, the topics of the synthetic drive, the container-independent
//! content of a log and the check of a bag that must be refused.

use pgm_datasets::bag::{read_bag, BagLog, BagTopics};
use pgm_datasets::Error;
use std::path::{Path, PathBuf};

/// A fresh, empty scratch folder `pgm-<group>-<process id>-<name>` in the temp dir.
pub fn temp_dir(group: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pgm-{group}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `bytes` to the file `name` in `dir` and returns its path.
pub fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// The topics of the synthetic drive (`pgm_datasets::bag::synthetic::drive`).
pub fn drive_topics() -> BagTopics {
    BagTopics {
        odometry: Some("/odom".into()),
        ego_pose: Some("/ego_pose".into()),
        object_pose: Some("/box_pose".into()),
        ..BagTopics::new("/scan")
    }
}

/// The parts of a log that must not depend on the container (what a bag gave, the
/// path left out).
pub fn content(log: &BagLog) -> impl PartialEq + std::fmt::Debug {
    (
        log.scans.clone(),
        log.odometry.clone(),
        log.ego_poses.clone(),
        log.object_poses.clone(),
    )
}

/// The error of a bag that must be refused (an [`Error::Bag`]), with every needle in
/// its message.
pub fn refused(path: &Path, topics: &BagTopics, needles: &[&str]) -> String {
    let e = read_bag(path, topics).expect_err("the bag must be refused");
    let text = e.to_string();
    assert!(matches!(e, Error::Bag { .. }), "{text}");
    for n in needles {
        assert!(text.contains(n), "{text:?} lacks {n:?}");
    }
    text
}
