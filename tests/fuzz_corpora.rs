//! The fuzz targets' seed corpora and every input that once crashed a reader
//! (`fuzz/corpus/<target>/`, `fuzz/regressions/<target>/`), replayed on stable through the same
//! entry points (`rift_render::untrusted`): each must return without panicking.

use crate::common;

use common::root;

#[test]
fn every_corpus_and_regression_input_reads_without_panicking() {
    let mut replayed = 0;
    for (target, read) in rift_render::untrusted::TARGETS {
        let mut inputs = 0;
        for folder in ["corpus", "regressions"] {
            let dir = root().join("fuzz").join(folder).join(target);
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for entry in entries {
                let path = entry.unwrap().path();
                let bytes = std::fs::read(&path).unwrap();
                let outcome = std::panic::catch_unwind(|| read(&bytes));
                assert!(outcome.is_ok(), "{target}: {} panicked", path.display());
                inputs += 1;
            }
        }
        assert!(
            inputs > 0,
            "{target}: no seed corpus in fuzz/corpus/{target}"
        );
        replayed += inputs;
    }
    eprintln!("replayed {replayed} inputs");
}
