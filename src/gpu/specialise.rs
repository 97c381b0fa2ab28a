//! Specialising a pass's naga module for its pipeline constants before the driver sees it.
//!
//! Drivers convert and optimise the whole SPIR-V module they are given before they fold a
//! specialisation constant: lavapipe spent as long creating a plane pipeline built for one
//! sun as one built for every kind of light. [`specialise`] therefore fixes the overrides
//! itself, replaces each `if` they decide by the branch taken, drops the code after a
//! `return` it keeps and compacts the module, so that only the code the constants can run
//! reaches the driver (docs/architecture.md, "The driver gets the module already
//! specialised").

/// `module` (entry point `main`) with its overrides fixed to `constants` (or their defaults),
/// each `if` whose condition is then a constant replaced by the branch it takes, and
/// everything no longer reachable from `main` removed. (Not validated again here: wgpu
/// validates a module when it is created; the unit tests validate every pass's.)
///
/// The pixels cannot change: the removed code is code the constants never run, and the
/// driver would have folded the same branches after converting them.
pub fn specialise(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    constants: &[(&str, f64)],
) -> std::result::Result<naga::Module, String> {
    let mut values = naga::back::PipelineConstants::default();
    for (key, value) in constants {
        values.insert((*key).to_string(), *value);
    }
    let (resolved, _) = naga::back::pipeline_constants::process_overrides(
        module,
        info,
        Some((naga::ShaderStage::Compute, "main")),
        &values,
    )
    .map_err(|e| format!("pipeline constants: {e}"))?;
    let mut module = resolved.into_owned();
    let constants = module.constants.clone();
    let globals = module.global_expressions.clone();
    for (_, function) in module.functions.iter_mut() {
        prune_function(function, &constants, &globals);
    }
    for entry in module.entry_points.iter_mut() {
        prune_function(&mut entry.function, &constants, &globals);
    }
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    Ok(module)
}

/// Removes from `function` the branches its constants decide, until none is left.
///
/// WGSL's `a && b` and `a || b` reach naga as a boolean local stored in both branches of an
/// `if a`, then loaded as the condition: once `if a` is decided one store is left, and a
/// local stored once with a constant is known after that store. So this runs again as long
/// as it removes something.
fn prune_function(
    function: &mut naga::Function,
    constants: &naga::Arena<naga::Constant>,
    globals: &naga::Arena<naga::Expression>,
) {
    let mut removed = Vec::new();
    loop {
        let once = stored_once(function);
        let mut pruner = Pruner {
            expressions: &function.expressions,
            constants,
            globals,
            stored_once: &once,
            removed: &mut removed,
            changed: false,
        };
        let mut known = Vec::new();
        pruner.block(&mut function.body, &mut known);
        if !pruner.changed {
            break;
        }
    }
    removed.sort();
    function
        .named_expressions
        .retain(|h, _| removed.binary_search(h).is_err());
}

/// A local variable and the expression its one store writes.
type StoredOnce = (
    naga::Handle<naga::LocalVariable>,
    naga::Handle<naga::Expression>,
);

/// The locals of `function` without an initialiser that one `Store` writes and nothing else
/// reaches but loads, with the expression stored.
fn stored_once(function: &naga::Function) -> Vec<StoredOnce> {
    use naga::Statement as S;
    let local_of = |h: naga::Handle<naga::Expression>| match function.expressions[h] {
        naga::Expression::LocalVariable(lv) => Some(lv),
        _ => None,
    };
    let mut stores: Vec<StoredOnce> = Vec::new();
    let mut excluded = Vec::new();
    let mut pending = vec![&function.body];
    while let Some(block) = pending.pop() {
        for statement in block.iter() {
            match *statement {
                S::Store { pointer, value } => {
                    if let Some(lv) = local_of(pointer) {
                        stores.push((lv, value));
                    }
                }
                S::Call { ref arguments, .. } => {
                    excluded.extend(arguments.iter().filter_map(|&a| local_of(a)));
                }
                S::Atomic { pointer, .. } => excluded.extend(local_of(pointer)),
                S::Block(ref b) => pending.push(b),
                S::If {
                    ref accept,
                    ref reject,
                    ..
                } => {
                    pending.push(accept);
                    pending.push(reject);
                }
                S::Loop {
                    ref body,
                    ref continuing,
                    ..
                } => {
                    pending.push(body);
                    pending.push(continuing);
                }
                S::Switch { ref cases, .. } => pending.extend(cases.iter().map(|c| &c.body)),
                _ => {}
            }
        }
    }
    // A local reached through an access (a member or an element) is left alone.
    for (_, e) in function.expressions.iter() {
        if let naga::Expression::Access { base, .. } | naga::Expression::AccessIndex { base, .. } =
            *e
        {
            excluded.extend(local_of(base));
        }
    }
    stores
        .iter()
        .filter(|&&(lv, _)| {
            stores.iter().filter(|(l, _)| *l == lv).count() == 1
                && !excluded.contains(&lv)
                && function.local_variables[lv].init.is_none()
        })
        .copied()
        .collect()
}

/// One pass of [`prune_function`] over a function's body.
struct Pruner<'a> {
    expressions: &'a naga::Arena<naga::Expression>,
    constants: &'a naga::Arena<naga::Constant>,
    globals: &'a naga::Arena<naga::Expression>,
    stored_once: &'a [StoredOnce],
    removed: &'a mut Vec<naga::Handle<naga::Expression>>,
    changed: bool,
}

/// Locals known to hold a boolean constant at a point of a body.
type Known = Vec<(naga::Handle<naga::LocalVariable>, bool)>;

impl Pruner<'_> {
    /// The value of boolean expression `h` if it is a literal, a constant's, or a load of a
    /// local in `known`.
    fn decided(&self, h: naga::Handle<naga::Expression>, known: &Known) -> Option<bool> {
        match self.expressions[h] {
            naga::Expression::Literal(naga::Literal::Bool(b)) => Some(b),
            naga::Expression::Constant(c) => match self.globals[self.constants[c].init] {
                naga::Expression::Literal(naga::Literal::Bool(b)) => Some(b),
                _ => None,
            },
            naga::Expression::Load { pointer } => match self.expressions[pointer] {
                naga::Expression::LocalVariable(lv) => {
                    known.iter().find(|(l, _)| *l == lv).map(|&(_, b)| b)
                }
                _ => None,
            },
            _ => None,
        }
    }

    /// Prunes `block`: a decided `if` is replaced by the statements of the branch it takes
    /// (spliced in, so that a store among them is known after them), and the statements
    /// after a `return`, `break`, `continue` or `kill` are dropped. `known` holds the locals
    /// known at the block's start; what is learnt inside stays inside.
    fn block(&mut self, block: &mut naga::Block, known: &mut Known) {
        use naga::Statement as S;
        let outer = known.len();
        let mut queue: std::collections::VecDeque<(naga::Statement, naga::Span)> =
            std::mem::take(block).span_into_iter().collect();
        while let Some((mut statement, span)) = queue.pop_front() {
            match statement {
                S::If {
                    condition,
                    ref mut accept,
                    ref mut reject,
                } => {
                    if let Some(taken) = self.decided(condition, known) {
                        let (kept, dropped) = if taken {
                            (accept, reject)
                        } else {
                            (reject, accept)
                        };
                        evaluated_in(dropped, self.removed);
                        let items: Vec<_> = std::mem::take(kept).span_into_iter().collect();
                        for item in items.into_iter().rev() {
                            queue.push_front(item);
                        }
                        self.changed = true;
                        continue;
                    }
                    self.block(accept, known);
                    self.block(reject, known);
                }
                S::Store { pointer, value } => {
                    if let naga::Expression::LocalVariable(lv) = self.expressions[pointer] {
                        let once = self.stored_once.contains(&(lv, value));
                        if let Some(b) = self.decided(value, known).filter(|_| once) {
                            known.push((lv, b));
                        }
                    }
                }
                S::Block(ref mut b) => self.block(b, known),
                S::Loop {
                    ref mut body,
                    ref mut continuing,
                    ..
                } => {
                    self.block(body, known);
                    self.block(continuing, known);
                }
                S::Switch { ref mut cases, .. } => {
                    for case in cases.iter_mut() {
                        self.block(&mut case.body, known);
                    }
                }
                _ => {}
            }
            let ends = matches!(
                statement,
                S::Return { .. } | S::Break | S::Continue | S::Kill
            );
            block.push(statement, span);
            if ends && !queue.is_empty() {
                let mut rest = naga::Block::new();
                for (st, sp) in queue.drain(..) {
                    rest.push(st, sp);
                }
                evaluated_in(&rest, self.removed);
                self.changed = true;
            }
        }
        known.truncate(outer);
    }
}

/// Adds to `out` every expression `block` evaluates: its emitted ranges and the results of
/// its calls, atomics and loads. A `let` naming one of them must go with the block, or
/// naga's compaction would keep a name for an expression whose statement is gone.
fn evaluated_in(block: &naga::Block, out: &mut Vec<naga::Handle<naga::Expression>>) {
    use naga::Statement as S;
    for statement in block.iter() {
        match *statement {
            S::Emit(ref range) => out.extend(range.clone()),
            S::Call {
                result: Some(h), ..
            }
            | S::Atomic {
                result: Some(h), ..
            }
            | S::WorkGroupUniformLoad { result: h, .. } => out.push(h),
            S::Block(ref b) => evaluated_in(b, out),
            S::If {
                ref accept,
                ref reject,
                ..
            } => {
                evaluated_in(accept, out);
                evaluated_in(reject, out);
            }
            S::Loop {
                ref body,
                ref continuing,
                ..
            } => {
                evaluated_in(body, out);
                evaluated_in(continuing, out);
            }
            S::Switch { ref cases, .. } => {
                for case in cases {
                    evaluated_in(&case.body, out);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shader::{parsed_module, passes, specialised_module, validator};

    /// Every pass specialised for its defaults, for each of its boolean overrides flipped,
    /// and for scene features of one kind of light each, of instances, textures and the
    /// bounce cache, and of none, validates (the pruning keeps naga's rules: splicing a
    /// branch into its block, dropping code after a return, compacting).
    #[test]
    fn every_pass_validates_specialised_for_each_override() {
        let masks = [0u32, 1, 2, 4, 8, 16, 32, 64, 128, 0x0f, 0x3f, u32::MAX];
        for name in passes() {
            let (module, info) = parsed_module(name).expect("parsed");
            let mut sets: Vec<Vec<(String, f64)>> = vec![Vec::new()];
            for (_, o) in module.overrides.iter() {
                let Some(oname) = o.name.clone() else {
                    continue;
                };
                let is_bool = matches!(
                    module.types[o.ty].inner,
                    naga::TypeInner::Scalar(naga::Scalar::BOOL)
                );
                // Overrides with an initialiser derived from others follow them.
                if oname == "SCENE_FEATURES" {
                    sets.extend(masks.iter().map(|&m| vec![(oname.clone(), f64::from(m))]));
                } else if is_bool && !oname.starts_with("SHADES_") && oname != "TRAVERSES_INSTANCES"
                {
                    sets.push(vec![(oname.clone(), 0.0)]);
                    sets.push(vec![(oname.clone(), 1.0)]);
                }
            }
            for set in sets {
                let constants: Vec<(&str, f64)> =
                    set.iter().map(|(k, v)| (k.as_str(), *v)).collect();
                let specialised = specialise(&module, &info, &constants)
                    .unwrap_or_else(|e| panic!("{name} {constants:?}: {e}"));
                validator()
                    .validate(&specialised)
                    .unwrap_or_else(|e| panic!("{name} {constants:?}: {e:?}"));
                assert_eq!(specialised.entry_points.len(), 1, "{name}");
            }
        }
    }

    /// The names of the functions left in `module`.
    fn functions(module: &naga::Module) -> Vec<String> {
        module
            .functions
            .iter()
            .filter_map(|(_, f)| f.name.clone())
            .collect()
    }

    fn specialised(text: &str, constants: &[(&str, f64)]) -> naga::Module {
        let module = naga::front::wgsl::parse_str(text).expect("parse");
        let info = validator().validate(&module).expect("validate");
        let specialised = specialise(&module, &info, constants).expect("specialise");
        validator()
            .validate(&specialised)
            .expect("the specialised module validates");
        specialised
    }

    /// A constant decides `if`s written plainly, through `&&` and `||` (which naga turns into
    /// a local stored in both branches of an `if`), down an `else if` chain, and the code
    /// after a `return` it keeps; the functions only dropped branches called go with them.
    #[test]
    fn specialising_removes_the_branches_its_constants_decide() {
        let text = "
            override A: bool = true;
            override B: bool = (MASK & 2u) != 0u;
            override MASK: u32 = 0xffffffffu;
            @group(0) @binding(0) var<storage, read_write> o: array<u32>;
            fn only_a() -> u32 { return 1u; }
            fn only_not_a() -> u32 { return 2u; }
            fn only_b() -> u32 { return 3u; }
            fn only_b_chain() -> u32 { return 4u; }
            fn after_return() -> u32 { return 5u; }
            fn always() -> u32 { return 6u; }
            fn pick(k: u32) -> u32 {
                if A && k == 1u {
                    return only_a();
                } else if B && k == 2u {
                    return only_b_chain();
                }
                return always();
            }
            fn early(k: u32) -> u32 {
                if !A || k == 7u {
                    return only_not_a();
                }
                if B {
                    return only_b();
                }
                return after_return();
            }
            @compute @workgroup_size(1) fn main() {
                o[0] = pick(o[1]) + early(o[2]);
            }";
        let all = functions(&specialised(text, &[]));
        for f in [
            "only_a",
            "only_not_a",
            "only_b",
            "only_b_chain",
            "always",
            "pick",
            "early",
        ] {
            assert!(
                all.iter().any(|n| n == f),
                "{f} missing by default: {all:?}"
            );
        }
        // B true: early() returns only_b() whenever it gets past the first test.
        assert!(!all.iter().any(|n| n == "after_return"), "{all:?}");

        let none = functions(&specialised(text, &[("A", 0.0), ("MASK", 0.0)]));
        for f in ["only_a", "only_b", "only_b_chain"] {
            assert!(
                !none.iter().any(|n| n == f),
                "{f} kept with A, B false: {none:?}"
            );
        }
        // !A is true: early() always returns only_not_a().
        assert!(none.iter().any(|n| n == "only_not_a"), "{none:?}");
        assert!(!none.iter().any(|n| n == "after_return"), "{none:?}");

        let a_only = functions(&specialised(text, &[("MASK", 1.0)]));
        assert!(a_only.iter().any(|n| n == "only_a"), "{a_only:?}");
        assert!(!a_only.iter().any(|n| n == "only_b_chain"), "{a_only:?}");
        assert!(a_only.iter().any(|n| n == "after_return"), "{a_only:?}");
    }

    /// Every pass that shades hits, specialised for one kind of light, keeps that kind's
    /// code and loses the others' (the rect light's solid-angle sampling, the environment
    /// map's), and every specialised module validates.
    #[test]
    fn passes_specialised_for_one_kind_of_light_leave_the_others_out() {
        use crate::gpu::SceneFeatures;
        let sun = 1u32 << crate::gpu::scene_buffers::LIGHT_SUN;
        let rect = 1u32 << crate::gpu::scene_buffers::LIGHT_RECT;
        let mut shading_passes = 0;
        for name in passes() {
            let text = crate::gpu::shader::compose(name).expect("compose");
            if !text.contains("fn rect_light_sample(") {
                continue;
            }
            let keeps = |bits: u32, f: &str| {
                let module = specialised_module(name, &[("SCENE_FEATURES", f64::from(bits))])
                    .unwrap_or_else(|e| panic!("{e}"));
                validator()
                    .validate(&module)
                    .unwrap_or_else(|e| panic!("{name} for features {bits:#x}: {e:?}"));
                functions(&module).iter().any(|n| n == f)
            };
            let every = SceneFeatures::ALL.bits();
            // Passes that sample lights at hits: every kind's code when built for any scene.
            if !keeps(every, "rect_light_sample") {
                continue;
            }
            shading_passes += 1;
            assert!(
                !keeps(sun, "rect_light_sample"),
                "{name}: rect sampling kept for a sun"
            );
            assert!(
                keeps(rect, "rect_light_sample"),
                "{name}: rect sampling lost"
            );
            if keeps(every, "environment_sample") {
                assert!(
                    !keeps(sun, "environment_sample"),
                    "{name}: the environment map's sampling kept for a sun"
                );
            }
        }
        assert!(
            shading_passes >= 4,
            "passes that shade lights: {shading_passes}"
        );
    }
}
