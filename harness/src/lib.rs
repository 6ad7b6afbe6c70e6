//! mapbench's harness as a library: the binary (`cli/main.rs`) is its CLI edge, and the fuzz
//! targets (`fuzz/`) drive the same readers the CLI uses.
//!
//! One folder per concern: `plan` turns a config and the dataset registry into the runs of a
//! batch, `run` executes them, `run_folder` owns every file of a run folder, `report` renders
//! tables, plots and the HTML pages (a run folder's, the history's trend, `compare`'s),
//! `gate` compares a run folder with a baseline, `export` writes the Newton systems of a
//! plan, `calibration` times the machine's reference workload, `history` keeps every batch in
//! an SQLite database, `signals` turns Ctrl-C, SIGTERM and SIGHUP into a clean stop, `slurm`
//! submits a batch to a Slurm cluster in shards balanced by expected time.
//!
//! The modules are layered one way (`scripts/layers.py` checks it): the leaves (`hash`,
//! `paths`, `stats`, `names`, `escape`, `convergence`, `signals`, `calibration`) name nothing
//! above them; `run_folder` only leaves; `plan`, `run`, `judge`, `history`, `gate`, `export`
//! `output`, `evaluate`, `external`, `slurm` and `corpus` (the shared corpus on demand) those two and each other, in no circle; `report` all of them; `cli` and
//! `fuzzing` are the edges. `run` and `merge` end with pages the report renders, so they are
//! handed a `run::Pages` rather than naming the report.

pub mod calibration;
pub mod claims;
pub mod column_names;
pub mod convergence;
pub mod corpus;
pub mod escape;
pub mod evaluate;
pub mod export;
pub mod external;
pub mod family;
pub mod fuzzing;
pub mod gate;
pub mod hardware;
pub mod hash;
pub mod history;
pub mod judge;
pub mod names;
pub mod output;
pub mod paths;
pub mod plan;
pub mod report;
pub mod run;
pub mod run_folder;
pub mod signals;
pub mod slurm;
pub mod stats;
pub mod utc;
