//! The skip-or-fail rule of `pgm_datasets::testdata` (one test in its own binary, as
//! it changes environment variables).

use pgm_datasets::testdata::{
    shared_case_file, shared_cases_dir, shared_data_dir, shared_data_file, SHARED_CASES_ENV,
    SHARED_DATA_ENV,
};

#[test]
fn missing_data_is_skipped_locally_and_fatal_under_ci() {
    let missing = std::env::temp_dir().join(format!("pgm-no-such-data-{}", std::process::id()));
    std::env::set_var(SHARED_DATA_ENV, &missing);
    std::env::set_var("CI", "false");
    assert_eq!(shared_data_dir(), None);
    std::env::set_var("CI", "true");
    assert!(std::panic::catch_unwind(shared_data_dir).is_err());

    // An existing folder is returned, and a missing file in it follows the same rule.
    let present = std::env::temp_dir().join(format!("pgm-data-{}", std::process::id()));
    std::fs::create_dir_all(&present).unwrap();
    std::fs::write(present.join("a.txt"), "x").unwrap();
    std::env::set_var(SHARED_DATA_ENV, &present);
    assert_eq!(shared_data_dir(), Some(present.clone()));
    assert_eq!(shared_data_file("a.txt"), Some(present.join("a.txt")));
    assert!(std::panic::catch_unwind(|| shared_data_file("b.txt")).is_err());
    std::env::set_var("CI", "false");
    assert_eq!(shared_data_file("b.txt"), None);

    // The cases: beside the data folder unless PGM_SHARED_CASES says otherwise.
    let data = present.join("data");
    std::fs::create_dir_all(&data).unwrap();
    std::env::set_var(SHARED_DATA_ENV, &data);
    std::env::remove_var(SHARED_CASES_ENV);
    assert_eq!(shared_cases_dir(), None);
    std::fs::create_dir_all(present.join("cases/kind")).unwrap();
    std::fs::write(present.join("cases/kind/in.bag"), "x").unwrap();
    assert_eq!(shared_cases_dir(), Some(present.join("cases")));
    assert_eq!(
        shared_case_file("kind/in.bag"),
        Some(present.join("cases/kind/in.bag"))
    );
    assert_eq!(shared_case_file("kind/other.bag"), None);
    std::env::set_var("CI", "true");
    assert!(std::panic::catch_unwind(|| shared_case_file("kind/other.bag")).is_err());
    std::env::set_var(SHARED_CASES_ENV, &missing);
    assert!(std::panic::catch_unwind(shared_cases_dir).is_err());
    std::env::set_var("CI", "false");
    assert_eq!(shared_cases_dir(), None);
    std::fs::remove_dir_all(&present).unwrap();
}
