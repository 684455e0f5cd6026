//! Which links move together in an articulated model (`bodies = "articulated"`), and which
//! joints stay as constraints.
//!
//! "Model only what the scene requires":
//!
//! 1. **Merging.** Links joined by a fixed joint, a joint named in `locked_joints`, or a mimic
//!    joint whose leader is merged, form one *group* (one rigid composite body, exactly as in
//!    `bodies = "rigid"`: a model whose joints are all fixed is one group, the rigid body).
//!    Revolute, continuous and prismatic joints between groups are kept.
//! 2. **Massless subtrees.** A kept joint whose whole subtree has no mass carries no inertia:
//!    its position is arbitrary and it cannot be integrated. Such joints are locked at their
//!    position (their links merged into the parent group) and reported (a warning).
//! 3. **Compound joints.** A massless group entered by a moving joint and left by one (a
//!    "virtual" link of a 2- or 3-DOF joint built from revolutes, as in example-robot-data's
//!    `human`) is not a body: the chain of two or three revolutes through one point from the
//!    nearest group with mass to the next becomes one compound joint (universal: 4 rows; ball:
//!    3 rows). Any other massless group entered by a moving joint is refused, naming the link
//!    and the ways out (give it mass, lock the joint).
//! 4. **Base.** With a floating base the root group is a body and must have mass; with a fixed
//!    base it is welded to the world (massless is fine).
//!
//! Multi-DOF URDF joints (`floating`, `planar`, `spherical`) are refused unless locked.
//! This module works in the model (root link) frame at the configuration the model was loaded
//! at ([`super::urdf::load`]); [`crate::scene`] turns the result into bodies and a
//! [`crate::sim::mechanism::Mechanism`].

use super::kinematics::{Joint, JointKind, axis_direction};
use super::{MassProperties, Model};
use crate::budget::readable;
use std::collections::{BTreeSet, HashMap};

/// A group of links moving as one body.
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// Link indices; `links[0]` is the group's root link (the child of its parent joint).
    pub links: Vec<usize>,
    /// Composite mass properties in the model frame, of the links with positive mass (`None`:
    /// the group is massless).
    pub composite: Option<MassProperties>,
}

/// A kept joint between two groups: one URDF joint, or a compound chain of two or three
/// revolutes with massless groups between.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupJoint {
    pub parent: usize,
    pub child: usize,
    /// URDF joint indices from the parent group to the child group.
    pub chain: Vec<usize>,
    /// The massless groups between consecutive chain joints (`chain.len() − 1` of them).
    pub interior: Vec<Group>,
}

/// The result of [`articulate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Articulation {
    /// Groups that are bodies (or, `groups[0]` with a fixed base, the welded root), parents
    /// before children; `groups[0]` holds the model's root link.
    pub groups: Vec<Group>,
    /// One per group but the root, `joints[k].child == k + 1`.
    pub joints: Vec<GroupJoint>,
    /// Joints locked because nothing with mass hangs from them.
    pub locked_massless: Vec<String>,
}

/// Why a model cannot be articulated; messages name the link or joint and the way out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ArticulationError {
    #[error(
        "joint `{joint}` is {kind}: articulated models keep revolute, continuous and prismatic joints only; lock it (locked_joints = [\"{joint}\"]) to treat it as fixed"
    )]
    MultiDof { joint: String, kind: &'static str },
    #[error(
        "locked_joints names `{joint}`, which mimics `{leader}`: lock `{leader}` instead (`{joint}` follows it)"
    )]
    LockedMimic { joint: String, leader: String },
    #[error(
        "link `{link}` has no mass and is entered by the moving joint `{joint}`; {why}. Give `{link}` mass (an <inertial>, or links.{link}.inertia = \"geometry\" in the scene), or lock `{joint}` (locked_joints = [\"{joint}\"])"
    )]
    MasslessLink {
        link: String,
        joint: String,
        why: String,
    },
    #[error(
        "the root link `{link}` has no mass, so with base = \"floating\" it cannot carry the moving joint `{joint}`: use base = \"fixed\", give `{link}` mass, or lock `{joint}`"
    )]
    MasslessRoot { link: String, joint: String },
    #[error(
        "joint `{joint}` mimics `{leader}`{why}: not supported in articulated mode; lock `{leader}`"
    )]
    UnsupportedMimic {
        joint: String,
        leader: String,
        why: String,
    },
    /// A kept joint whose axis is no direction (zero, NaN or infinite): its constraint rows
    /// would be NaN from the first step.
    #[error(
        "joint `{joint}` moves about or along its axis [{}, {}, {}], which has no direction (it \
         must be a non-zero vector of finite numbers): fix the URDF's <axis xyz>, or lock \
         `{joint}` (locked_joints = [\"{joint}\"])",
        readable(.axis[0]), readable(.axis[1]), readable(.axis[2])
    )]
    BadAxis { joint: String, axis: [f64; 3] },
    /// Mimic joints whose leaders lead back to them: `joints[0]` mimics `joints[1]`, ..., the
    /// last mimics `joints[0]` (one joint mimicking itself is a cycle of one). Their
    /// constraints determine no position (the solver's matrix is singular).
    #[error(
        "the mimic joints form a cycle ({}): each follows the next, so none of them is set by a \
         joint that moves freely; remove the <mimic> of one of them",
        cycle_text(.joints)
    )]
    MimicCycle { joints: Vec<String> },
}

/// `a` mimics `b` mimics `a`, as `` `a` mimics `b`, `b` mimics `a` ``.
fn cycle_text(joints: &[String]) -> String {
    (0..joints.len())
        .map(|k| {
            format!(
                "`{}` mimics `{}`",
                joints[k],
                joints[(k + 1) % joints.len()]
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The first cycle of mimic joints of `joints` (each joint follows at most one leader, named
/// by `<mimic joint>`; a name that is no joint leads nowhere), in file order of its first
/// joint: the joints from it following their leaders until it comes back.
pub fn mimic_cycle(joints: &[Joint]) -> Option<Vec<String>> {
    let by_name: HashMap<&str, usize> = joints
        .iter()
        .enumerate()
        .map(|(i, j)| (j.name.as_str(), i))
        .collect();
    let leader = |i: usize| -> Option<usize> {
        let m = joints[i].mimic.as_ref()?;
        by_name.get(m.joint.as_str()).copied()
    };
    // 0: not seen, 1: on the current walk, 2: leads to no cycle (or to one already found).
    let mut state = vec![0u8; joints.len()];
    for start in 0..joints.len() {
        let mut walk = Vec::new();
        let mut at = Some(start);
        while let Some(i) = at {
            match state[i] {
                0 => {
                    state[i] = 1;
                    walk.push(i);
                    at = leader(i);
                }
                1 => {
                    let first = walk.iter().position(|&w| w == i).expect("on the walk");
                    return Some(
                        walk[first..]
                            .iter()
                            .map(|&w| joints[w].name.clone())
                            .collect(),
                    );
                }
                _ => break,
            }
        }
        for w in walk {
            state[w] = 2;
        }
    }
    None
}

/// Tolerance on coincident joint origins of a compound joint, m.
const COINCIDENT_M: f64 = 1e-9;

/// Groups and kept joints of `model` (see the module doc). `locked` names joints to merge
/// (checked to exist by the caller); `fixed_base` welds the root to the world.
pub fn articulate(
    model: &Model,
    locked: &BTreeSet<String>,
    fixed_base: bool,
) -> Result<Articulation, ArticulationError> {
    let by_name: HashMap<&str, usize> = model
        .joints
        .iter()
        .enumerate()
        .map(|(i, j)| (j.name.as_str(), i))
        .collect();
    if let Some(joints) = mimic_cycle(&model.joints) {
        return Err(ArticulationError::MimicCycle { joints });
    }
    // 1. Which joints merge their links.
    let mut merged = vec![false; model.joints.len()];
    for (i, joint) in model.joints.iter().enumerate() {
        merged[i] = joint.kind == JointKind::Fixed || locked.contains(&joint.name);
        if locked.contains(&joint.name)
            && let Some(m) = &joint.mimic
        {
            return Err(ArticulationError::LockedMimic {
                joint: joint.name.clone(),
                leader: m.joint.clone(),
            });
        }
        if !merged[i] && !joint.kind.is_single_dof() {
            return Err(ArticulationError::MultiDof {
                joint: joint.name.clone(),
                kind: joint.kind.as_str(),
            });
        }
    }
    // Mimic followers of merged leaders merge too (to a fixed point: chains of mimics).
    loop {
        let mut changed = false;
        for (i, joint) in model.joints.iter().enumerate() {
            if merged[i] {
                continue;
            }
            if let Some(m) = &joint.mimic
                && let Some(&l) = by_name.get(m.joint.as_str())
                && merged[l]
            {
                merged[i] = true;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let children = children_of(model);
    // 2. Massless subtrees below kept joints: lock (repeat until stable, deepest first is not
    // needed: a subtree without mass stays without mass when merged).
    let link_mass = |l: usize| model.links[l].inertial.map_or(0.0, |mp| mp.mass.max(0.0));
    let mut subtree_mass = vec![0.0; model.links.len()];
    let order = preorder(model, &children);
    for &l in order.iter().rev() {
        subtree_mass[l] = link_mass(l)
            + children[l]
                .iter()
                .map(|&j| subtree_mass[model.joints[j].child])
                .sum::<f64>();
    }
    let mut locked_massless = Vec::new();
    for &l in &order {
        for &j in &children[l] {
            let child = model.joints[j].child;
            if !merged[j] && subtree_mass[child] <= 0.0 {
                merged[j] = true;
                locked_massless.push(model.joints[j].name.clone());
            }
        }
    }
    // Every kept joint moves about or along its axis: it must have a direction.
    for (j, joint) in model.joints.iter().enumerate() {
        if !merged[j] && axis_direction(&joint.axis).is_none() {
            return Err(ArticulationError::BadAxis {
                joint: joint.name.clone(),
                axis: joint.axis.into(),
            });
        }
    }
    // Mimic rules on the kept joints: the leader must be kept too (a merged leader merged the
    // follower above), and neither may be inside a compound chain (checked below).
    // 3. Groups: walk the tree; a merged joint keeps the child in its parent's group.
    let mut group_of = vec![usize::MAX; model.links.len()];
    let mut pre_groups: Vec<Vec<usize>> = Vec::new();
    let mut entering: Vec<Option<usize>> = Vec::new();
    for &l in &order {
        let parent_joint = model.joints.iter().position(|j| j.child == l);
        match parent_joint {
            Some(j) if merged[j] => {
                let g = group_of[model.joints[j].parent];
                group_of[l] = g;
                pre_groups[g].push(l);
            }
            _ => {
                group_of[l] = pre_groups.len();
                pre_groups.push(vec![l]);
                entering.push(parent_joint);
            }
        }
    }
    let composite = |links: &[usize]| {
        let parts: Vec<MassProperties> = links
            .iter()
            .filter_map(|&l| {
                let link = &model.links[l];
                let mp = link.inertial.as_ref().filter(|mp| mp.mass > 0.0)?;
                Some(mp.transformed(&link.model_from_link))
            })
            .collect();
        if parts.is_empty() {
            None
        } else {
            MassProperties::combine(&parts)
        }
    };
    let groups: Vec<Group> = pre_groups
        .iter()
        .map(|links| Group {
            links: links.clone(),
            composite: composite(links),
        })
        .collect();
    // Kept joints between pre-groups: entering[g] for g > 0.
    let massive = |g: usize| groups[g].composite.is_some();
    let root_link = &model.links[model.root].name;
    if !fixed_base
        && !massive(0)
        && let Some(j) = (1..groups.len()).find_map(|g| entering[g])
    {
        return Err(ArticulationError::MasslessRoot {
            link: root_link.clone(),
            joint: model.joints[j].name.clone(),
        });
    }
    // 4. Bodies: the root group and every massive group; massless groups inside chains.
    let mut body_of = vec![usize::MAX; groups.len()];
    let mut out_groups = vec![groups[0].clone()];
    body_of[0] = 0;
    let mut out_joints = Vec::new();
    let group_children = |g: usize| -> Vec<usize> {
        (1..groups.len())
            .filter(|&c| {
                let j = entering[c].expect("a non-root group has an entering joint");
                group_of[model.joints[j].parent] == g
            })
            .collect()
    };
    let mut stack = vec![0usize];
    while let Some(g) = stack.pop() {
        for c in group_children(g).into_iter().rev() {
            // Follow massless groups down to the next massive one.
            let mut chain = vec![entering[c].unwrap()];
            let mut interior = Vec::new();
            let mut at = c;
            while !massive(at) {
                let link = &model.links[groups[at].links[0]].name;
                let joint = &model.joints[*chain.last().unwrap()].name;
                let kids = group_children(at);
                if kids.len() != 1 {
                    return Err(ArticulationError::MasslessLink {
                        link: link.clone(),
                        joint: joint.clone(),
                        why: format!(
                            "it carries {} moving joints (a compound joint needs exactly one)",
                            kids.len()
                        ),
                    });
                }
                interior.push(groups[at].clone());
                at = kids[0];
                chain.push(entering[at].unwrap());
            }
            if chain.len() > 1 {
                check_compound(model, &chain, &groups[c])?;
            }
            for &j in &chain {
                if let Some(m) = &model.joints[j].mimic
                    && chain.len() > 1
                {
                    return Err(ArticulationError::UnsupportedMimic {
                        joint: model.joints[j].name.clone(),
                        leader: m.joint.clone(),
                        why: " inside a compound joint".into(),
                    });
                }
            }
            body_of[at] = out_groups.len();
            out_groups.push(groups[at].clone());
            out_joints.push(GroupJoint {
                parent: body_of[g],
                child: body_of[at],
                chain,
                interior,
            });
            stack.push(at);
        }
    }
    // Mimic leaders must be kept joints that are not compound stages.
    let simple: BTreeSet<usize> = out_joints
        .iter()
        .filter(|j| j.chain.len() == 1)
        .map(|j| j.chain[0])
        .collect();
    for j in &simple {
        if let Some(m) = &model.joints[*j].mimic {
            let leader = by_name.get(m.joint.as_str()).copied();
            if !leader.is_some_and(|l| simple.contains(&l)) {
                return Err(ArticulationError::UnsupportedMimic {
                    joint: model.joints[*j].name.clone(),
                    leader: m.joint.clone(),
                    why: " (the leader is not a kept single joint)".into(),
                });
            }
        }
    }
    Ok(Articulation {
        groups: out_groups,
        joints: out_joints,
        locked_massless,
    })
}

/// A compound chain must be two or three revolutes (or continuous) whose joint origins
/// coincide and whose axes are independent.
fn check_compound(
    model: &Model,
    chain: &[usize],
    first_interior: &Group,
) -> Result<(), ArticulationError> {
    let link = model.links[first_interior.links[0]].name.clone();
    let joint = model.joints[chain[0]].name.clone();
    let refuse = |why: String| ArticulationError::MasslessLink {
        link: link.clone(),
        joint: joint.clone(),
        why,
    };
    if chain.len() > 3 {
        return Err(refuse(format!(
            "it starts a chain of {} joints through massless links (a compound joint has two or three)",
            chain.len()
        )));
    }
    let origin = |j: &Joint| {
        let parent_pose = model.links[j.parent].model_from_link;
        (parent_pose * j.parent_from_joint).translation.vector
    };
    let axis = |j: &Joint| {
        let parent_pose = model.links[j.parent].model_from_link;
        (parent_pose * j.parent_from_joint).rotation
            * axis_direction(&j.axis).map_or_else(nalgebra::Vector3::zeros, |u| u.into_inner())
    };
    let o0 = origin(&model.joints[chain[0]]);
    let mut axes = Vec::new();
    for &j in chain {
        let jt = &model.joints[j];
        if !matches!(jt.kind, JointKind::Revolute | JointKind::Continuous) {
            return Err(refuse(format!(
                "the chain through it contains the {} joint `{}` (a compound joint is made of revolutes)",
                jt.kind.as_str(),
                jt.name
            )));
        }
        let d = (origin(jt) - o0).norm();
        if d > COINCIDENT_M {
            return Err(refuse(format!(
                "the origins of `{}` and `{}` are {d:.3e} m apart (a compound joint's revolutes must meet at one point)",
                model.joints[chain[0]].name, jt.name
            )));
        }
        axes.push(axis(jt));
    }
    let independent = match axes.len() {
        2 => axes[0].cross(&axes[1]).norm() > 1e-6,
        _ => axes[0].cross(&axes[1]).dot(&axes[2]).abs() > 1e-6,
    };
    if !independent {
        return Err(refuse(
            "the axes of the revolutes through it are parallel or coplanar (no compound joint)"
                .into(),
        ));
    }
    Ok(())
}

/// Per link: the joints of which it is the parent.
fn children_of(model: &Model) -> Vec<Vec<usize>> {
    let mut children = vec![Vec::new(); model.links.len()];
    for (j, joint) in model.joints.iter().enumerate() {
        children[joint.parent].push(j);
    }
    children
}

/// Links from the root, parents before children (file order among siblings).
fn preorder(model: &Model, children: &[Vec<usize>]) -> Vec<usize> {
    let mut order = Vec::with_capacity(model.links.len());
    let mut stack = vec![model.root];
    while let Some(l) = stack.pop() {
        order.push(l);
        for &j in children[l].iter().rev() {
            stack.push(model.joints[j].child);
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::kinematics::Mimic;
    use nalgebra::{Isometry3, Vector3};

    /// Joints named `names`, joint `k` mimicking `leaders[k]` (when given).
    fn joints(leaders: &[(&str, Option<&str>)]) -> Vec<Joint> {
        leaders
            .iter()
            .enumerate()
            .map(|(k, (name, leader))| Joint {
                name: name.to_string(),
                kind: JointKind::Revolute,
                parent: k,
                child: k + 1,
                parent_from_joint: Isometry3::identity(),
                axis: Vector3::z(),
                mimic: leader.map(|l| Mimic {
                    joint: l.to_string(),
                    multiplier: 1.0,
                    offset: 0.0,
                }),
                limits: None,
                damping: 0.0,
                friction: 0.0,
                effort_limit: 0.0,
                velocity_limit: 0.0,
            })
            .collect()
    }

    #[test]
    fn mimic_cycles_of_any_length_are_found() {
        let names = |v: &[&str]| Some(v.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        // Self, pair, triple (entered from a joint leading into it: the cycle alone).
        assert_eq!(mimic_cycle(&joints(&[("a", Some("a"))])), names(&["a"]));
        assert_eq!(
            mimic_cycle(&joints(&[("x", None), ("a", Some("b")), ("b", Some("a"))])),
            names(&["a", "b"])
        );
        assert_eq!(
            mimic_cycle(&joints(&[
                ("d", Some("a")),
                ("a", Some("b")),
                ("b", Some("c")),
                ("c", Some("a")),
            ])),
            names(&["a", "b", "c"])
        );
        // Chains, a missing leader and shared leaders are no cycle.
        assert_eq!(
            mimic_cycle(&joints(&[
                ("a", Some("b")),
                ("b", Some("c")),
                ("c", None),
                ("d", Some("c")),
                ("e", Some("ghost")),
            ])),
            None
        );
        let e = ArticulationError::MimicCycle {
            joints: vec!["a".into(), "b".into()],
        };
        assert_eq!(
            e.to_string(),
            "the mimic joints form a cycle (`a` mimics `b`, `b` mimics `a`): each follows the \
             next, so none of them is set by a joint that moves freely; remove the <mimic> of one \
             of them"
        );
    }
}
