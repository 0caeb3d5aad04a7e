//! `dagger train`: a policy fitted on every round of a dataset, with its training and
//! held-out errors per action number, written as a policy artifact.

use std::path::Path;

use crate::artifact::{ArtifactBuilder, Lineage, Manifest, digest_input};
use crate::dagger::dataset::Dataset;
use crate::dagger::{PolicyKind, PolicyLearner};
use crate::error::{Error, Result};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};

/// What `dagger train` fits, as the user asked.
#[derive(Debug, clap::Args)]
pub struct TrainOptions {
    #[arg(long, value_enum, default_value = "ridge")]
    pub learner: PolicyKind,
    /// Ridge and logistic: the penalty on standardised observations; mlp: the weight
    /// decay.
    #[arg(long, default_value_t = 1e-3)]
    pub lambda: f64,
    #[arg(long, default_value_t = 3)]
    pub depth: usize,
    /// mlp: the hidden layers' widths.
    #[arg(long, value_delimiter = ',', default_value = "64,64")]
    pub hidden: Vec<usize>,
    /// mlp: passes over the data.
    #[arg(long, default_value_t = 200)]
    pub epochs: usize,
    /// mlp: the seed of the initial weights and the minibatch order.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The share of episodes held out (spread evenly over the dataset) to report the
    /// policy's error per action number on episodes it was not fitted on.
    #[arg(long, default_value_t = 0.0)]
    pub validation: f64,
}

/// Whether episode `e` (numbered across the dataset) is held out when a `share` of the
/// episodes are: evenly spread, the same ones on every run (with 0.2: 4, 9, 14, ...).
fn held_out(e: u64, share: f64) -> bool {
    ((e + 1) as f64 * share).floor() > (e as f64 * share).floor()
}

/// Fits a policy on every round of the DAgger dataset at `dataset` (less the held-out
/// share of episodes) and writes it as a policy artifact at `out`.
pub fn train_policy(dataset: &Path, out: &Path, options: &TrainOptions) -> Result<Manifest> {
    let (learner, lambda, depth) = (options.learner, options.lambda, options.depth);
    crate::artifact::check_replaceable(out)?;
    let ds = Dataset::open(dataset)?;
    if ds.steps() == 0 {
        return Err(Error::input(dataset, "holds no steps to train on"));
    }
    let classes = if learner.discrete() && ds.info.action_dims() > 1 {
        return Err(Error::Usage(format!(
            "discrete learners take an action of one number (a class); this dataset's \
             actions hold {} ({})",
            ds.info.action_dims(),
            ds.info.action_names.join(", ")
        )));
    } else if learner.discrete() {
        action_classes(&ds, dataset)?
    } else if ds.info.environment == "gridnav" {
        return Err(Error::Usage(
            "gridnav's moves are classes, not numbers: --learner logistic or class-tree".into(),
        ));
    } else {
        0
    };
    let mut learner = learner.learner(depth, lambda, classes);
    if let PolicyLearner::Mlp(config) = &mut learner {
        if options.hidden.contains(&0) || options.epochs == 0 {
            return Err(Error::Usage(
                "--hidden widths and --epochs must be at least 1".into(),
            ));
        }
        config.hidden = options.hidden.clone();
        config.epochs = options.epochs;
        config.seed = options.seed;
    }
    let share = options.validation;
    if !(0.0..1.0).contains(&share) {
        return Err(Error::Usage(format!(
            "--validation {share}: a share of the episodes, at least 0 and below 1"
        )));
    }
    let fitted_on = |e: u64| !held_out(e, share);
    // Ridge keeps only the sufficient statistics; a tree needs the rows.
    let data = ds.aggregate_episodes(&learner, fitted_on)?;
    if data.is_empty() {
        return Err(Error::input(
            dataset,
            format!(
                "holds no steps to train on once a share of {share} of its episodes is held out"
            ),
        ));
    }
    let policy = data.fit(&learner);
    let mut artifact = ArtifactBuilder::new(out)?;
    write_bytes_atomic(
        &artifact.file("policy.json", "policy")?,
        &to_json_bytes(&policy),
    )?;
    let mut metrics = serde_json::json!({
        "rounds": ds.rounds.len(),
        "steps": ds.steps(),
        "observation_names": ds.info.observation_names,
    });
    if !ds.info.action_names.is_empty() {
        metrics["action_names"] = serde_json::json!(ds.info.action_names);
    }
    if !ds.info.action_names.is_empty() || share > 0.0 {
        metrics["training_rmse_per_action"] =
            serde_json::json!(ds.errors_per_action(|o| policy.act_all(o), fitted_on)?);
    }
    if share > 0.0 {
        metrics["validation_share"] = serde_json::json!(share);
        metrics["validation_rmse_per_action"] =
            serde_json::json!(ds.errors_per_action(|o| policy.act_all(o), |e| held_out(e, share))?);
        // What always answering the training episodes' mean action scores: a policy
        // that does not beat it has learned nothing from the observations.
        let mean = ds.mean_action(fitted_on)?;
        metrics["validation_mean_action_rmse_per_action"] =
            serde_json::json!(ds.errors_per_action(|_| mean.clone(), |e| held_out(e, share))?);
    }
    write_bytes_atomic(
        &artifact.file("metrics.json", "metrics")?,
        &to_json_bytes(&metrics),
    )?;
    let params = serde_json::json!({
        "learner": format!("{learner:?}"),
    });
    let lineage = Lineage::new(
        "dagger-train",
        1,
        params,
        vec![digest_input(&dataset.join(crate::artifact::MANIFEST))?],
    );
    artifact.commit("policy", lineage, metrics)
}

/// The number of discrete actions in a dataset (the largest label + 1), refusing labels
/// that are not class indices.
fn action_classes(ds: &Dataset, dataset: &Path) -> Result<usize> {
    const MOST_CLASSES: f64 = 256.0;
    let mut largest = 0.0f64;
    ds.for_each_round(|info, steps| {
        for (i, &label) in (0..steps.len()).map(|i| &steps.label(i)[0]).enumerate() {
            if !((0.0..MOST_CLASSES).contains(&label) && label.fract() == 0.0) {
                return Err(Error::input(
                    dataset,
                    format!(
                        "round {} step {i}: label {label} is not a class index (a discrete \
                         learner needs actions 0, 1, ... below {MOST_CLASSES})",
                        info.round
                    ),
                ));
            }
            largest = largest.max(label);
        }
        Ok(())
    })?;
    Ok(largest as usize + 1)
}

#[cfg(test)]
mod tests {
    use super::held_out;

    #[test]
    fn held_out_episodes_are_spread_evenly_and_stable() {
        let picked = |share: f64| (0..10).filter(|&e| held_out(e, share)).collect::<Vec<_>>();
        assert_eq!(picked(0.2), [4, 9]);
        assert_eq!(picked(0.5), [1, 3, 5, 7, 9]);
        assert!(picked(0.0).is_empty());
    }
}
