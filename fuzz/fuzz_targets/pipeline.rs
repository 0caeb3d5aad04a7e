//! Pipeline YAML on arbitrary text: parsing, expansion of `foreach` and `vars`, and
//! building every stage from its parameters. Errors, never panics.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // As the binary does: panics the readers catch on purpose (third-party decoders on
    // damaged files) are errors; any other panic still aborts for the fuzzer.
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(imitate::error::install_panic_hook);
    let path = std::env::temp_dir().join(format!("imitate-fuzz-pipeline-{}.yaml", std::process::id()));
    std::fs::write(&path, data).unwrap();
    let Ok(spec) = imitate::pipeline::load(&path) else {
        return;
    };
    let Ok(stages) = spec.expand() else {
        return;
    };
    for stage in stages {
        if let Ok(built) = imitate::stage::build(&stage.uses, stage.with) {
            let _ = (built.deps(), built.out(), built.params());
        }
    }
});
