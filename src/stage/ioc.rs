//! `ioc`: inverse optimal control on a tabular MDP from Parquet (transitions, per-state
//! features, demonstrations): LEARCH (ridge or trees), MMP or MaxEnt; out comes a reward
//! artifact, the learned reward per state with the action of its optimal policy.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::ArtifactBuilder;
use crate::error::{Error, Result};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::io::mdp_tables::{read_state_features, read_trajectories, read_transitions};
use crate::io::tables::{Table, write_numeric_table};
use crate::ioc::objectworld::state_action_reward;
use crate::ioc::tabular::{Method, TabularConfig, TabularProblem, learn};
use crate::plan::{Backup, value_iteration};

pub const KIND: &str = "ioc";
const VERSION: u32 = 1;

fn default_discount() -> f64 {
    0.9
}

/// Parameters of `imitate ioc` and of `uses: ioc`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IocParams {
    /// Transitions: columns state, action, next_state (integers), prob.
    #[arg(long, value_name = "FILE")]
    pub transitions: PathBuf,
    /// Per-state features: column state (0..n, one row each) and one numeric column per
    /// feature.
    #[arg(long, value_name = "FILE")]
    pub features: PathBuf,
    /// Demonstrations: columns trajectory (integer), t, state.
    #[arg(long, value_name = "FILE")]
    pub demonstrations: PathBuf,
    #[arg(long, value_enum)]
    pub method: Method,
    #[arg(long, default_value_t = default_discount())]
    #[serde(default = "default_discount")]
    pub discount: f64,
    /// Rounds; default per method (LEARCH and MMP 100, MaxEnt 40).
    #[arg(long)]
    #[serde(default)]
    pub rounds: Option<usize>,
    /// Step size; default per method.
    #[arg(long)]
    #[serde(default)]
    pub step_size: Option<f64>,
    /// The reward artifact folder to write.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

impl StageParams for IocParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        vec![
            self.transitions.clone(),
            self.features.clone(),
            self.demonstrations.clone(),
        ]
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        if !(0.0..1.0).contains(&self.discount) {
            return Err(Error::Usage("ioc: discount must be in [0, 1)".into()));
        }
        if self.rounds == Some(0) || self.step_size.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
            return Err(Error::Usage(
                "ioc: rounds must be at least 1 and step_size positive".into(),
            ));
        }
        let (features, names, states) = read_state_features(&self.features)?;
        let mdp = read_transitions(&self.transitions, states)?;
        let demonstrations = read_trajectories(&self.demonstrations, states)?;
        let defaults = TabularConfig::default_for(self.method);
        let config = TabularConfig {
            rounds: self.rounds.unwrap_or(defaults.rounds),
            step_size: self.step_size.unwrap_or(defaults.step_size),
            ..defaults
        };
        let problem = TabularProblem {
            mdp: &mdp,
            discount: self.discount,
            features: &features,
            dims: names.len(),
            demonstrations: &demonstrations,
        };
        let reward = learn(&problem, self.method, &config);
        let policy = value_iteration(
            &mdp,
            &state_action_reward(&mdp, &reward),
            self.discount,
            Backup::Hard,
            1e-9,
            100_000,
        )
        .policy(Backup::Hard);
        let actions = mdp.actions();
        let action: Vec<f64> = policy
            .chunks(actions)
            .map(|row| row.iter().position(|p| *p > 0.0).unwrap_or(0) as f64)
            .collect();
        let state: Vec<f64> = (0..states).map(|s| s as f64).collect();

        let mut out = ArtifactBuilder::new(&self.out)?;
        write_numeric_table(
            &out.file("reward.parquet", "reward")?,
            Table::LEARNED_REWARD,
            &[("state", &state), ("reward", &reward), ("action", &action)],
        )?;
        let demonstrated_states: usize = demonstrations.iter().map(|d| d.states.len()).sum();
        let metrics = serde_json::json!({
            "method": self.method.name(),
            "states": states,
            "actions": actions,
            "features": names,
            "demonstrations": demonstrations.len(),
            "demonstrated_states": demonstrated_states,
            "config": config,
        });
        write_bytes_atomic(
            &out.file("metrics.json", "metrics")?,
            &to_json_bytes(&metrics),
        )?;
        let summary = format!(
            "{} on {states} states x {actions} actions, {} demonstrations",
            self.method.name(),
            demonstrations.len()
        );
        commit_artifact(self, extra_deps, out, "reward", metrics, summary)
    }
}
