//! Policies as standard ONNX models, so that a robot's own stack (onnxruntime in C++,
//! Python, on the robot) runs what `dagger train` fitted. The graph takes
//! `observation` (float32, [N, D]) and gives `action` (float32, [N, A]):
//!
//! - linear policies: the standardisation, one `Gemm` for every output, the clamp to
//!   each output's range (`Max`, `Min`);
//! - trees: `ai.onnx.ml.TreeEnsembleRegressor`, one tree per output, then the clamp;
//! - networks: the standardisation, a `Gemm` per layer with `Relu` between, the
//!   targets' scale and mean, the clamp;
//! - logistic regression and classification trees (discrete actions): the class scores
//!   (`Gemm` or a tree ensemble), `ArgMax` (the first of equal scores, as `act`), the
//!   class index as a float in `action` [N, 1].
//!
//! The model runs in float32: observations within float32 rounding of a tree's
//! threshold may branch the other way than the float64 policy. Mixtures and
//! forward-training sequences choose a member per episode or step, which one ONNX
//! model cannot: they are refused.
//!
//! The protobuf messages are the subset of `onnx.proto3` this writer fills, with its
//! field numbers.

use prost::Message;

use super::policy::{LinearPolicy, LogisticPolicy, MlpPolicy, Policy};
use crate::learn::{Node, RegressionTree};

/// ONNX IR version 8 and opsets 17 (ai.onnx) and 3 (ai.onnx.ml): what onnxruntime
/// since 1.14 runs.
const IR_VERSION: i64 = 8;
const OPSET: i64 = 17;
const ML_OPSET: i64 = 3;

mod proto {
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct ModelProto {
        #[prost(int64, tag = "1")]
        pub ir_version: i64,
        #[prost(string, tag = "2")]
        pub producer_name: String,
        #[prost(string, tag = "3")]
        pub producer_version: String,
        #[prost(string, tag = "6")]
        pub doc_string: String,
        #[prost(message, optional, tag = "7")]
        pub graph: Option<GraphProto>,
        #[prost(message, repeated, tag = "8")]
        pub opset_import: Vec<OperatorSetIdProto>,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct OperatorSetIdProto {
        #[prost(string, tag = "1")]
        pub domain: String,
        #[prost(int64, tag = "2")]
        pub version: i64,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct GraphProto {
        #[prost(message, repeated, tag = "1")]
        pub node: Vec<NodeProto>,
        #[prost(string, tag = "2")]
        pub name: String,
        #[prost(message, repeated, tag = "5")]
        pub initializer: Vec<TensorProto>,
        #[prost(message, repeated, tag = "11")]
        pub input: Vec<ValueInfoProto>,
        #[prost(message, repeated, tag = "12")]
        pub output: Vec<ValueInfoProto>,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct NodeProto {
        #[prost(string, repeated, tag = "1")]
        pub input: Vec<String>,
        #[prost(string, repeated, tag = "2")]
        pub output: Vec<String>,
        #[prost(string, tag = "3")]
        pub name: String,
        #[prost(string, tag = "4")]
        pub op_type: String,
        #[prost(message, repeated, tag = "5")]
        pub attribute: Vec<AttributeProto>,
        #[prost(string, tag = "7")]
        pub domain: String,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct AttributeProto {
        #[prost(string, tag = "1")]
        pub name: String,
        #[prost(float, tag = "2")]
        pub f: f32,
        #[prost(int64, tag = "3")]
        pub i: i64,
        #[prost(bytes = "vec", tag = "4")]
        pub s: Vec<u8>,
        #[prost(float, repeated, tag = "7")]
        pub floats: Vec<f32>,
        #[prost(int64, repeated, tag = "8")]
        pub ints: Vec<i64>,
        #[prost(bytes = "vec", repeated, tag = "9")]
        pub strings: Vec<Vec<u8>>,
        /// AttributeType: FLOAT 1, INT 2, STRING 3, FLOATS 6, INTS 7, STRINGS 8.
        #[prost(int32, tag = "20")]
        pub r#type: i32,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TensorProto {
        #[prost(int64, repeated, tag = "1")]
        pub dims: Vec<i64>,
        /// FLOAT 1, INT64 7.
        #[prost(int32, tag = "2")]
        pub data_type: i32,
        #[prost(float, repeated, tag = "4")]
        pub float_data: Vec<f32>,
        #[prost(int64, repeated, tag = "7")]
        pub int64_data: Vec<i64>,
        #[prost(string, tag = "8")]
        pub name: String,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct ValueInfoProto {
        #[prost(string, tag = "1")]
        pub name: String,
        #[prost(message, optional, tag = "2")]
        pub r#type: Option<TypeProto>,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TypeProto {
        #[prost(message, optional, tag = "1")]
        pub tensor_type: Option<TensorTypeProto>,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TensorTypeProto {
        #[prost(int32, tag = "1")]
        pub elem_type: i32,
        #[prost(message, optional, tag = "2")]
        pub shape: Option<TensorShapeProto>,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TensorShapeProto {
        #[prost(message, repeated, tag = "1")]
        pub dim: Vec<Dimension>,
    }

    #[derive(Clone, PartialEq, prost::Message)]
    pub struct Dimension {
        #[prost(int64, optional, tag = "1")]
        pub dim_value: Option<i64>,
        #[prost(string, optional, tag = "2")]
        pub dim_param: Option<String>,
    }
}

use proto::{
    AttributeProto, Dimension, GraphProto, ModelProto, NodeProto, OperatorSetIdProto, TensorProto,
    TensorShapeProto, TensorTypeProto, TypeProto, ValueInfoProto,
};

const FLOAT: i32 = 1;
const ML_DOMAIN: &str = "ai.onnx.ml";

fn attribute(name: &str) -> AttributeProto {
    AttributeProto {
        name: name.into(),
        ..Default::default()
    }
}

fn int(name: &str, value: i64) -> AttributeProto {
    AttributeProto {
        i: value,
        r#type: 2,
        ..attribute(name)
    }
}

fn text(name: &str, value: &str) -> AttributeProto {
    AttributeProto {
        s: value.as_bytes().to_vec(),
        r#type: 3,
        ..attribute(name)
    }
}

fn floats(name: &str, values: Vec<f32>) -> AttributeProto {
    AttributeProto {
        floats: values,
        r#type: 6,
        ..attribute(name)
    }
}

fn ints(name: &str, values: Vec<i64>) -> AttributeProto {
    AttributeProto {
        ints: values,
        r#type: 7,
        ..attribute(name)
    }
}

fn texts(name: &str, values: Vec<&str>) -> AttributeProto {
    AttributeProto {
        strings: values.into_iter().map(|s| s.as_bytes().to_vec()).collect(),
        r#type: 8,
        ..attribute(name)
    }
}

fn tensor(name: &str, dims: Vec<i64>, values: Vec<f32>) -> TensorProto {
    TensorProto {
        dims,
        data_type: FLOAT,
        float_data: values,
        name: name.into(),
        ..Default::default()
    }
}

/// A float32 tensor of shape [N, width] (N free).
fn batch_of(name: &str, width: usize) -> ValueInfoProto {
    let dim = |value: Option<i64>, param: Option<&str>| Dimension {
        dim_value: value,
        dim_param: param.map(String::from),
    };
    ValueInfoProto {
        name: name.into(),
        r#type: Some(TypeProto {
            tensor_type: Some(TensorTypeProto {
                elem_type: FLOAT,
                shape: Some(TensorShapeProto {
                    dim: vec![dim(None, Some("N")), dim(Some(width as i64), None)],
                }),
            }),
        }),
    }
}

/// A graph under construction: nodes and initializers (each helper is used once per
/// graph, so their fixed names do not collide).
#[derive(Default)]
struct Graph {
    nodes: Vec<NodeProto>,
    initializers: Vec<TensorProto>,
}

impl Graph {
    fn constant(&mut self, name: &str, dims: Vec<i64>, values: Vec<f32>) -> String {
        self.initializers.push(tensor(name, dims, values));
        name.to_string()
    }

    fn node(
        &mut self,
        op: &str,
        domain: &str,
        inputs: &[&str],
        output: &str,
        attributes: Vec<AttributeProto>,
    ) -> String {
        self.nodes.push(NodeProto {
            input: inputs.iter().map(|s| s.to_string()).collect(),
            output: vec![output.into()],
            name: format!("{op}_{}", self.nodes.len()),
            op_type: op.into(),
            attribute: attributes,
            domain: domain.into(),
        });
        output.to_string()
    }

    /// (x − mean) / scale.
    fn standardise(&mut self, x: &str, mean: &[f64], scale: &[f64]) -> String {
        let d = mean.len() as i64;
        let m = self.constant("mean", vec![d], mean.iter().map(|&v| v as f32).collect());
        let s = self.constant("scale", vec![d], scale.iter().map(|&v| v as f32).collect());
        let centred = self.node("Sub", "", &[x, &m], "centred", vec![]);
        self.node("Div", "", &[&centred, &s], "standardised", vec![])
    }

    /// Gemm(z, W, b) with W given per output as rows (`weights[j]` for output j).
    fn affine(&mut self, z: &str, weights: &[Vec<f64>], bias: &[f64], output: &str) -> String {
        let (outputs, d) = (weights.len(), weights.first().map_or(0, Vec::len));
        let w: Vec<f32> = weights.iter().flatten().map(|&v| v as f32).collect();
        let w = self.constant("weights", vec![outputs as i64, d as i64], w);
        let b = self.constant(
            "bias",
            vec![outputs as i64],
            bias.iter().map(|&v| v as f32).collect(),
        );
        self.node("Gemm", "", &[z, &w, &b], output, vec![int("transB", 1)])
    }

    /// Each output clamped to its own [low, high].
    fn clamp(&mut self, y: &str, ranges: &[[f64; 2]], output: &str) -> String {
        let a = ranges.len() as i64;
        let low = self.constant("low", vec![a], ranges.iter().map(|r| r[0] as f32).collect());
        let high = self.constant(
            "high",
            vec![a],
            ranges.iter().map(|r| r[1] as f32).collect(),
        );
        let floor = self.node("Max", "", &[y, &low], "floored", vec![]);
        self.node("Min", "", &[&floor, &high], output, vec![])
    }

    /// One tree per target of a `TreeEnsembleRegressor` (target j is tree j's value).
    fn trees(&mut self, x: &str, trees: &[&RegressionTree], output: &str) -> String {
        #[derive(Default)]
        struct Flat {
            tree: Vec<i64>,
            node: Vec<i64>,
            feature: Vec<i64>,
            mode: Vec<&'static str>,
            value: Vec<f32>,
            yes: Vec<i64>,
            no: Vec<i64>,
            target_tree: Vec<i64>,
            target_node: Vec<i64>,
            target_id: Vec<i64>,
            target_weight: Vec<f32>,
        }
        // Nodes numbered in preorder within each tree; returns the node's id.
        fn walk(flat: &mut Flat, tree: i64, node: &Node, next: &mut i64) -> i64 {
            let id = *next;
            *next += 1;
            let at = flat.node.len();
            flat.tree.push(tree);
            flat.node.push(id);
            match node {
                Node::Leaf { value } => {
                    flat.feature.push(0);
                    flat.mode.push("LEAF");
                    flat.value.push(0.0);
                    flat.yes.push(0);
                    flat.no.push(0);
                    flat.target_tree.push(tree);
                    flat.target_node.push(id);
                    flat.target_id.push(tree);
                    flat.target_weight.push(*value as f32);
                }
                Node::Split {
                    feature,
                    threshold,
                    left,
                    right,
                } => {
                    flat.feature.push(*feature as i64);
                    // Rows with feature <= threshold go left, the "true" branch.
                    flat.mode.push("BRANCH_LEQ");
                    flat.value.push(*threshold as f32);
                    flat.yes.push(0);
                    flat.no.push(0);
                    let yes = walk(flat, tree, left, next);
                    let no = walk(flat, tree, right, next);
                    flat.yes[at] = yes;
                    flat.no[at] = no;
                }
            }
            id
        }
        let mut flat = Flat::default();
        for (t, tree) in trees.iter().enumerate() {
            walk(&mut flat, t as i64, &tree.root, &mut 0);
        }
        let attributes = vec![
            text("aggregate_function", "SUM"),
            int("n_targets", trees.len() as i64),
            ints("nodes_falsenodeids", flat.no),
            ints("nodes_featureids", flat.feature),
            texts("nodes_modes", flat.mode),
            ints("nodes_nodeids", flat.node),
            ints("nodes_treeids", flat.tree),
            ints("nodes_truenodeids", flat.yes),
            floats("nodes_values", flat.value),
            text("post_transform", "NONE"),
            ints("target_ids", flat.target_id),
            ints("target_nodeids", flat.target_node),
            ints("target_treeids", flat.target_tree),
            floats("target_weights", flat.target_weight),
        ];
        self.node("TreeEnsembleRegressor", ML_DOMAIN, &[x], output, attributes)
    }

    /// The index of the largest score per row, as a float column [N, 1].
    fn class_of(&mut self, scores: &str, output: &str) -> String {
        let index = self.node(
            "ArgMax",
            "",
            &[scores],
            "class",
            vec![
                int("axis", 1),
                int("keepdims", 1),
                int("select_last_index", 0),
            ],
        );
        self.node("Cast", "", &[&index], output, vec![int("to", FLOAT as i64)])
    }
}

/// The members of a policy that acts with one model per output.
fn members(policy: &Policy) -> Vec<&Policy> {
    match policy {
        Policy::Outputs { members } => members.iter().collect(),
        other => vec![other],
    }
}

/// The ONNX model of `policy`, whose observations are `observation_names`.
pub fn policy_model(policy: &Policy, observation_names: &[String]) -> Result<Vec<u8>, String> {
    let d = observation_names.len();
    let outputs = members(policy);
    let mut graph = Graph::default();
    let (action, width) = match outputs.as_slice() {
        [Policy::Logistic(p)] => {
            let scores = logistic_scores(&mut graph, p);
            (graph.class_of(&scores, "action"), 1)
        }
        [Policy::Mlp(p)] => (mlp(&mut graph, p), p.ranges.len()),
        [Policy::ClassTrees { trees }] => {
            let trees: Vec<&RegressionTree> = trees.iter().collect();
            let scores = graph.trees("observation", &trees, "scores");
            (graph.class_of(&scores, "action"), 1)
        }
        many if many.iter().all(|m| matches!(m, Policy::Linear(_))) => {
            let linear: Vec<&LinearPolicy> = many
                .iter()
                .filter_map(|m| match m {
                    Policy::Linear(p) => Some(p),
                    _ => None,
                })
                .collect();
            let first = linear[0];
            if linear
                .iter()
                .any(|p| p.mean != first.mean || p.scale != first.scale)
            {
                return Err("the outputs were standardised differently".into());
            }
            let z = graph.standardise("observation", &first.mean, &first.scale);
            let weights: Vec<Vec<f64>> = linear.iter().map(|p| p.weights.clone()).collect();
            let bias: Vec<f64> = linear.iter().map(|p| p.bias).collect();
            let y = graph.affine(&z, &weights, &bias, "unclamped");
            let ranges: Vec<[f64; 2]> = linear.iter().map(|p| p.range).collect();
            (graph.clamp(&y, &ranges, "action"), linear.len())
        }
        many if many.iter().all(|m| matches!(m, Policy::Tree { .. })) => {
            let (trees, ranges): (Vec<&RegressionTree>, Vec<[f64; 2]>) = many
                .iter()
                .filter_map(|m| match m {
                    Policy::Tree { tree, range } => Some((tree, *range)),
                    _ => None,
                })
                .unzip();
            let y = graph.trees("observation", &trees, "unclamped");
            (graph.clamp(&y, &ranges, "action"), trees.len())
        }
        _ => {
            return Err(format!(
                "a {} policy chooses a member per episode or step; one ONNX model cannot",
                match policy {
                    Policy::Sequence { .. } => "forward-training",
                    Policy::Mixture { .. } => "mixture",
                    _ => "mixed",
                }
            ));
        }
    };
    debug_assert_eq!(action, "action");
    let model = ModelProto {
        ir_version: IR_VERSION,
        producer_name: "imitate".into(),
        producer_version: env!("CARGO_PKG_VERSION").into(),
        doc_string: format!(
            "observation: float32 [N, {d}] ({}); action: float32 [N, {width}]",
            observation_names.join(", ")
        ),
        graph: Some(GraphProto {
            node: graph.nodes,
            name: "policy".into(),
            initializer: graph.initializers,
            input: vec![batch_of("observation", d)],
            output: vec![batch_of("action", width)],
        }),
        opset_import: vec![
            OperatorSetIdProto {
                domain: String::new(),
                version: OPSET,
            },
            OperatorSetIdProto {
                domain: ML_DOMAIN.into(),
                version: ML_OPSET,
            },
        ],
    };
    Ok(model.encode_to_vec())
}

/// Writes the ONNX model of the policy artifact `dir` to `path` (atomically); the
/// observation names come from the artifact's metrics.
pub fn write_policy_model(
    dir: &std::path::Path,
    path: &std::path::Path,
) -> crate::error::Result<()> {
    use crate::error::Error;
    let (policy, _) = super::load_policy_artifact(dir)?;
    let names = super::policy_observation_names(dir);
    if names.is_empty() {
        return Err(Error::input(
            dir.join("metrics.json"),
            "names no observations (observation_names): the model's input size is unknown",
        ));
    }
    let bytes = policy_model(&policy, &names)
        .map_err(|e| Error::input(dir, format!("cannot be exported as ONNX: {e}")))?;
    crate::io::fs::write_bytes_atomic(path, &bytes)
}

/// The network's layers on the standardised observation, then the targets' scale.
fn mlp(graph: &mut Graph, p: &MlpPolicy) -> String {
    let mut x = graph.standardise("observation", &p.mean, &p.scale);
    let last = p.network.layers.len() - 1;
    for (k, layer) in p.network.layers.iter().enumerate() {
        let weights = graph.constant(
            &format!("layer{k}_weights"),
            vec![layer.outputs as i64, layer.inputs as i64],
            layer.weights.iter().map(|&v| v as f32).collect(),
        );
        let bias = graph.constant(
            &format!("layer{k}_bias"),
            vec![layer.outputs as i64],
            layer.bias.iter().map(|&v| v as f32).collect(),
        );
        let out = format!("layer{k}");
        x = graph.node(
            "Gemm",
            "",
            &[&x, &weights, &bias],
            &out,
            vec![int("transB", 1)],
        );
        if k < last {
            x = graph.node("Relu", "", &[&x], &format!("layer{k}_relu"), vec![]);
        }
    }
    let a = p.target_scale.len() as i64;
    let to_f32 = |v: &[f64]| v.iter().map(|&v| v as f32).collect::<Vec<f32>>();
    let scale = graph.constant("target_scale", vec![a], to_f32(&p.target_scale));
    let mean = graph.constant("target_mean", vec![a], to_f32(&p.target_mean));
    let scaled = graph.node("Mul", "", &[&x, &scale], "scaled", vec![]);
    let y = graph.node("Add", "", &[&scaled, &mean], "unclamped", vec![]);
    graph.clamp(&y, &p.ranges, "action")
}

/// Per class: intercept + w · standardised x.
fn logistic_scores(graph: &mut Graph, p: &LogisticPolicy) -> String {
    let z = graph.standardise("observation", &p.mean, &p.scale);
    let weights: Vec<Vec<f64>> = p.weights.iter().map(|w| w[1..].to_vec()).collect();
    let bias: Vec<f64> = p.weights.iter().map(|w| w[0]).collect();
    graph.affine(&z, &weights, &bias, "scores")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_decode_back_with_their_graph() {
        let linear = Policy::Linear(LinearPolicy {
            mean: vec![1.0, 2.0],
            scale: vec![0.5, 4.0],
            weights: vec![0.3, -0.2],
            bias: 0.1,
            range: [-1.0, 1.0],
        });
        let names = ["a".to_string(), "b".to_string()];
        let bytes = policy_model(&linear, &names).unwrap();
        let model = ModelProto::decode(bytes.as_slice()).unwrap();
        let graph = model.graph.unwrap();
        let ops: Vec<&str> = graph.node.iter().map(|n| n.op_type.as_str()).collect();
        assert_eq!(ops, ["Sub", "Div", "Gemm", "Max", "Min"]);
        assert_eq!(graph.output[0].name, "action");
        let tree = Policy::Tree {
            tree: RegressionTree {
                root: Node::Split {
                    feature: 1,
                    threshold: 0.5,
                    left: Box::new(Node::Leaf { value: -1.0 }),
                    right: Box::new(Node::Leaf { value: 2.0 }),
                },
            },
            range: [-1.0, 2.0],
        };
        let model = ModelProto::decode(policy_model(&tree, &names).unwrap().as_slice()).unwrap();
        let ensemble = &model.graph.unwrap().node[0];
        assert_eq!(ensemble.domain, ML_DOMAIN);
        let modes = ensemble
            .attribute
            .iter()
            .find(|a| a.name == "nodes_modes")
            .unwrap();
        assert_eq!(
            modes.strings,
            [b"BRANCH_LEQ".to_vec(), b"LEAF".to_vec(), b"LEAF".to_vec()]
        );
        let mixture = Policy::Mixture {
            members: vec![linear.clone(), linear],
        };
        let err = policy_model(&mixture, &names).unwrap_err();
        assert!(err.contains("mixture"), "{err}");
    }
}
