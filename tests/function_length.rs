//! Functions stay short enough to read: none outside tests runs over 150 lines, and one over 100
//! lines says why in a comment starting with `// Long:`, inside the function or directly above it
//! (e.g. `// Long: one match arm per setting; splitting hides the table`).
//!
//! Every `.rs` file under `crates/`, `src/` and `examples/` is parsed (`tests/` folders, `target`
//! and `fuzz/` are skipped, as are `#[cfg(test)]` items and `#[test]` functions), and every free
//! function, method, trait method with a body and nested function is measured from its `fn` line to
//! its closing brace. The allow-lists below excuse functions that may stay as they are for now; an
//! entry that no longer excuses anything fails the test too, so the lists only shrink.

use std::{
    fs,
    path::{Path, PathBuf},
};

use anyhow::{bail, Context, Result};
use syn::{
    punctuated::Punctuated,
    spanned::Spanned,
    visit::{self, Visit},
    Attribute, Block, ImplItemFn, ItemFn, ItemImpl, ItemMod, ItemTrait, Meta, Signature, Token,
    TraitItemFn,
};

/// No function outside tests is longer than this.
const MAX_LINES: usize = 150;
/// A function longer than this says why, in a comment starting with [`REASON_MARK`].
const REASON_NEEDED_OVER: usize = 100;
const REASON_MARK: &str = "// Long:";

const SOURCE_ROOTS: &[&str] = &["crates", "src", "examples"];
const SKIPPED_FOLDERS: &[&str] = &["tests", "target", "fuzz"];

/// Functions over [`MAX_LINES`] that may stay so for now, as (file, name); they need no reason
/// either. The name is the one the failure message prints (`Type::method`, `outer::inner`).
const ALLOWED_OVER_MAX: &[(&str, &str)] = &[];

/// Functions over [`REASON_NEEDED_OVER`] lines (and at most [`MAX_LINES`]) that may stay without a
/// `// Long:` reason for now, as (file, name).
const ALLOWED_WITHOUT_REASON: &[(&str, &str)] = &[];

#[test]
fn no_function_outside_tests_is_too_long() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut functions = Vec::new();
    for file in source_files(root)? {
        let relative = file
            .strip_prefix(root)?
            .to_string_lossy()
            .replace('\\', "/");
        let source =
            fs::read_to_string(&file).with_context(|| format!("reading {}", file.display()))?;
        functions.extend(measure(&relative, &source)?);
    }
    assert!(
        functions.len() > 100,
        "only {} functions found: is the source walk looking in the right folders?",
        functions.len()
    );
    let problems = problems(&functions, ALLOWED_OVER_MAX, ALLOWED_WITHOUT_REASON);
    if !problems.is_empty() {
        bail!(
            "{} function length problem(s); split the function into named steps, or (over \
             {REASON_NEEDED_OVER} lines and at most {MAX_LINES}) say why it is long in a \
             `{REASON_MARK}` comment:\n{}",
            problems.len(),
            problems.join("\n")
        );
    }
    Ok(())
}

/// The measuring itself: lengths, names, reasons and what is skipped, on a made-up file.
#[test]
fn measures_functions_names_them_and_finds_reasons() -> Result<()> {
    let body = |lines: usize| "    let _ = 1;\n".repeat(lines - 2);
    let source = format!(
        "fn short() {{\n{}}}\n\
         // Long: a stated reason.\n\
         /// Documented.\n\
         #[inline]\n\
         fn reasoned() {{\n{}}}\n\
         struct Thing;\n\
         impl Thing {{\n    fn method() {{\n{}    }}\n}}\n\
         trait Shape {{\n    fn area(&self) -> f32;\n    fn outer() {{\n        fn inner() {{\n{}        }}\n    }}\n}}\n\
         #[cfg(test)]\nmod tests {{\n    fn helper() {{\n{}    }}\n}}\n\
         #[cfg(all(test, feature = \"x\"))]\nfn only_in_tests() {{\n{}}}\n\
         #[test]\nfn a_test() {{\n{}}}\n",
        body(10),
        body(120),
        body(151),
        body(101),
        body(200),
        body(200),
        body(200),
    );
    let measured: Vec<(String, usize, bool)> = measure("made/up.rs", &source)?
        .into_iter()
        .map(|function| (function.name, function.lines, function.has_reason))
        .collect();
    let expected = [
        ("short", 10, false),
        ("reasoned", 120, true),
        ("Thing::method", 151, false),
        ("Shape::outer", 103, false),
        ("Shape::outer::inner", 101, false),
    ]
    .map(|(name, lines, reason)| (name.to_string(), lines, reason));
    assert_eq!(measured, expected);

    let functions = measure("made/up.rs", &source)?;
    let found = problems(&functions, &[], &[]);
    assert_eq!(
        found,
        [
            "made/up.rs:136 Thing::method: 151 lines, over 150",
            "made/up.rs:290 Shape::outer: 103 lines and no `// Long:` reason",
            "made/up.rs:291 Shape::outer::inner: 101 lines and no `// Long:` reason",
        ]
    );
    let excused = problems(
        &functions,
        &[("made/up.rs", "Thing::method"), ("made/up.rs", "reasoned")],
        &[
            ("made/up.rs", "Shape::outer"),
            ("made/up.rs", "Shape::outer::inner"),
            ("made/up.rs", "gone"),
        ],
    );
    assert_eq!(
        excused,
        [
            "allow-list entry made/up.rs reasoned is not over 150 lines (120): remove it",
            "allow-list entry made/up.rs gone is not a function over 100 lines without a reason: \
             remove it",
        ]
    );
    Ok(())
}

/// One measured function.
struct Function {
    file: String,
    /// The line of its `fn`.
    line: usize,
    /// `name`, `Type::name` for a method, `outer::inner` for a nested function.
    name: String,
    /// From the `fn` line to the closing brace, both included.
    lines: usize,
    /// A `// Long:` comment inside it or directly above it.
    has_reason: bool,
}

fn problems(
    functions: &[Function],
    allowed_over_max: &[(&str, &str)],
    allowed_without_reason: &[(&str, &str)],
) -> Vec<String> {
    let listed = |list: &[(&str, &str)], function: &Function| {
        list.iter()
            .any(|&(file, name)| file == function.file && name == function.name)
    };
    let mut problems = Vec::new();
    for function in functions {
        let Function {
            file,
            line,
            name,
            lines,
            ..
        } = function;
        if *lines > MAX_LINES {
            if !listed(allowed_over_max, function) {
                problems.push(format!(
                    "{file}:{line} {name}: {lines} lines, over {MAX_LINES}"
                ));
            }
        } else if *lines > REASON_NEEDED_OVER
            && !function.has_reason
            && !listed(allowed_without_reason, function)
        {
            problems.push(format!(
                "{file}:{line} {name}: {lines} lines and no `{REASON_MARK}` reason"
            ));
        }
    }
    for &(file, name) in allowed_over_max {
        let matching: Vec<&Function> = functions
            .iter()
            .filter(|function| function.file == file && function.name == name)
            .collect();
        if matching.is_empty() {
            problems.push(format!(
                "allow-list entry {file} {name} is not a function: remove it"
            ));
        } else if matching.iter().all(|function| function.lines <= MAX_LINES) {
            let lines = matching
                .iter()
                .map(|function| function.lines)
                .max()
                .unwrap_or(0);
            problems.push(format!(
                "allow-list entry {file} {name} is not over {MAX_LINES} lines ({lines}): remove it"
            ));
        }
    }
    for &(file, name) in allowed_without_reason {
        let still_excused = functions.iter().any(|function| {
            function.file == file
                && function.name == name
                && (REASON_NEEDED_OVER + 1..=MAX_LINES).contains(&function.lines)
                && !function.has_reason
        });
        if !still_excused {
            problems.push(format!(
                "allow-list entry {file} {name} is not a function over {REASON_NEEDED_OVER} lines \
                 without a reason: remove it"
            ));
        }
    }
    problems
}

/// Every `.rs` file under [`SOURCE_ROOTS`], sorted, outside [`SKIPPED_FOLDERS`].
fn source_files(root: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let mut folders: Vec<PathBuf> = SOURCE_ROOTS.iter().map(|name| root.join(name)).collect();
    while let Some(folder) = folders.pop() {
        for entry in
            fs::read_dir(&folder).with_context(|| format!("listing {}", folder.display()))?
        {
            let path = entry?.path();
            let name = path.file_name().unwrap_or_default().to_string_lossy();
            if path.is_dir() {
                if !name.starts_with('.') && !SKIPPED_FOLDERS.contains(&name.as_ref()) {
                    folders.push(path);
                }
            } else if name.ends_with(".rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    Ok(files)
}

/// The functions of one file, in the order they appear (an outer function before its nested ones).
fn measure(file: &str, source: &str) -> Result<Vec<Function>> {
    let syntax = syn::parse_file(source).with_context(|| format!("parsing {file}"))?;
    let mut collector = Collector {
        file,
        source_lines: source.lines().collect(),
        scope: Vec::new(),
        functions: Vec::new(),
    };
    collector.visit_file(&syntax);
    let mut functions = collector.functions;
    functions.sort_by_key(|function| function.line);
    Ok(functions)
}

struct Collector<'a> {
    file: &'a str,
    source_lines: Vec<&'a str>,
    /// The names around the current item: impl or trait type, then enclosing functions.
    scope: Vec<String>,
    functions: Vec<Function>,
}

impl Collector<'_> {
    fn record(&mut self, attrs: &[Attribute], signature: &Signature, body: &Block) {
        let first = signature.fn_token.span.start().line;
        let last = body.brace_token.span.close().end().line;
        let item_start = attrs
            .iter()
            .map(|attribute| attribute.span().start().line)
            .chain([first])
            .min()
            .unwrap_or(first);
        let name = self
            .scope
            .iter()
            .cloned()
            .chain([signature.ident.to_string()])
            .collect::<Vec<_>>()
            .join("::");
        self.functions.push(Function {
            file: self.file.to_string(),
            line: first,
            name,
            lines: last + 1 - first,
            has_reason: self.has_reason(item_start, last),
        });
    }

    /// A `// Long:` comment with some text in lines `item_start..=last` (1-based) or in the comment
    /// lines right above them.
    fn has_reason(&self, item_start: usize, last: usize) -> bool {
        let is_reason = |line: &&str| {
            line.trim_start()
                .strip_prefix(REASON_MARK)
                .is_some_and(|reason| !reason.trim().is_empty())
        };
        let own = &self.source_lines[item_start - 1..last.min(self.source_lines.len())];
        let mut above = self.source_lines[..item_start - 1]
            .iter()
            .rev()
            .take_while(|line| line.trim_start().starts_with("//"));
        own.iter().any(is_reason) || above.any(is_reason)
    }

    fn within<T>(&mut self, name: String, visit: impl FnOnce(&mut Self) -> T) -> T {
        self.scope.push(name);
        let result = visit(self);
        self.scope.pop();
        result
    }
}

impl<'ast> Visit<'ast> for Collector<'_> {
    fn visit_item_mod(&mut self, module: &'ast ItemMod) {
        if !is_test_only(&module.attrs) {
            visit::visit_item_mod(self, module);
        }
    }

    fn visit_item_impl(&mut self, block: &'ast ItemImpl) {
        if !is_test_only(&block.attrs) {
            // `Type` for `impl Type` and `impl Trait for path::Type<T>`; the text otherwise.
            let self_type = match &*block.self_ty {
                syn::Type::Path(path) => path.path.segments.last().map(|s| s.ident.to_string()),
                other => other.span().source_text(),
            };
            let self_type = self_type.unwrap_or_else(|| "_".to_string());
            self.within(self_type, |this| visit::visit_item_impl(this, block));
        }
    }

    fn visit_item_trait(&mut self, definition: &'ast ItemTrait) {
        if !is_test_only(&definition.attrs) {
            let name = definition.ident.to_string();
            self.within(name, |this| visit::visit_item_trait(this, definition));
        }
    }

    fn visit_item_fn(&mut self, function: &'ast ItemFn) {
        if !is_test_only(&function.attrs) && !is_test_function(&function.attrs) {
            self.record(&function.attrs, &function.sig, &function.block);
            let name = function.sig.ident.to_string();
            self.within(name, |this| visit::visit_item_fn(this, function));
        }
    }

    fn visit_impl_item_fn(&mut self, function: &'ast ImplItemFn) {
        if !is_test_only(&function.attrs) && !is_test_function(&function.attrs) {
            self.record(&function.attrs, &function.sig, &function.block);
            let name = function.sig.ident.to_string();
            self.within(name, |this| visit::visit_impl_item_fn(this, function));
        }
    }

    fn visit_trait_item_fn(&mut self, function: &'ast TraitItemFn) {
        if is_test_only(&function.attrs) {
            return;
        }
        if let Some(body) = &function.default {
            self.record(&function.attrs, &function.sig, body);
        }
        let name = function.sig.ident.to_string();
        self.within(name, |this| visit::visit_trait_item_fn(this, function));
    }
}

/// `#[test]` or a test attribute of another crate (`#[tokio::test]`).
fn is_test_function(attrs: &[Attribute]) -> bool {
    attrs.iter().any(|attribute| {
        attribute
            .path()
            .segments
            .last()
            .is_some_and(|segment| segment.ident == "test")
    })
}

/// `#[cfg(test)]`, or `#[cfg(all(test, ...))]`.
fn is_test_only(attrs: &[Attribute]) -> bool {
    fn requires_test(condition: &Meta) -> bool {
        match condition {
            Meta::Path(path) => path.is_ident("test"),
            Meta::List(list) if list.path.is_ident("all") => list
                .parse_args_with(Punctuated::<Meta, Token![,]>::parse_terminated)
                .is_ok_and(|conditions| conditions.iter().any(requires_test)),
            _ => false,
        }
    }
    attrs.iter().any(|attribute| {
        attribute.path().is_ident("cfg")
            && attribute
                .parse_args::<Meta>()
                .is_ok_and(|condition| requires_test(&condition))
    })
}
