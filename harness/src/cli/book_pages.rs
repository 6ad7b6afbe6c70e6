//! The book's generated reference pages: every verb and flag from clap's definitions (the
//! `--help` texts), so the page cannot drift from the binary. A test compares the committed
//! page with what this renders; `MAPBENCH_BLESS_DOCS=1` rewrites it.

#[cfg(test)]
use clap::{Arg, ArgAction, Command};

/// `docs/src/reference/cli.md`: each verb's purpose, usage and arguments.
#[cfg(test)]
pub fn cli_markdown(mut cli: Command) -> String {
    cli.build();
    let mut s = String::from(
        "# Command line\n\n<!-- Generated from the binary's argument definitions: `MAPBENCH_BLESS_DOCS=1 cargo test \
         --release --bin mapbench reference` rewrites it; a test fails when it differs. -->\n\n\
         Every verb of `mapbench` with its arguments, as `mapbench <verb> --help` prints them. Exit codes are on \
         [their own page](exit-codes.md).\n",
    );
    for sub in cli.get_subcommands().filter(|c| !c.is_hide_set() && c.get_name() != "help") {
        let name = sub.get_name();
        s += &format!("\n## `mapbench {name}`\n\n");
        if let Some(about) = sub.get_long_about().or(sub.get_about()) {
            let about = angles(&one_paragraph(&about.to_string()));
            s += &format!("{about}{}\n\n", if about.ends_with('.') { "" } else { "." });
        }
        let usage = sub.clone().render_usage().to_string();
        s += &format!("```text\n{}\n```\n\n", usage.trim());
        let args: Vec<&Arg> = sub
            .get_arguments()
            .filter(|a| !a.is_hide_set() && a.get_id() != "help" && a.get_id() != "version")
            .collect();
        if args.is_empty() {
            continue;
        }
        s += "| argument | meaning |\n|---|---|\n";
        for a in args {
            s += &format!("| {} | {} |\n", cell(&arg_name(a)), cell(&angles(&arg_meaning(a))));
        }
    }
    s
}

/// `--out <OUT>`, `-x, --flag`, `<CONFIG>...`.
#[cfg(test)]
fn arg_name(a: &Arg) -> String {
    let values: Vec<String> = a.get_value_names().map_or_else(
        || vec![a.get_id().as_str().to_uppercase()],
        |v| v.iter().map(|n| n.as_str().to_string()).collect(),
    );
    let takes_value = !matches!(a.get_action(), ArgAction::SetTrue | ArgAction::SetFalse | ArgAction::Count);
    let many = matches!(a.get_action(), ArgAction::Append);
    let dots = if many { "..." } else { "" };
    if a.is_positional() {
        return format!("`<{}>{dots}`", values.join("> <"));
    }
    let mut names: Vec<String> = Vec::new();
    if let Some(c) = a.get_short() {
        names.push(format!("-{c}"));
    }
    if let Some(l) = a.get_long() {
        names.push(format!("--{l}"));
    }
    let value = if takes_value { format!(" <{}>", values.join("> <")) } else { String::new() };
    format!("`{}{value}`{dots}", names.join(", "))
}

/// The help text, then the default and the accepted values.
#[cfg(test)]
fn arg_meaning(a: &Arg) -> String {
    let mut m = a.get_long_help().or(a.get_help()).map(|h| one_paragraph(&h.to_string())).unwrap_or_default();
    if !m.is_empty() && !m.ends_with('.') {
        m.push('.');
    }
    if a.is_required_set() {
        m += " Required.";
    }
    let defaults: Vec<String> = a.get_default_values().iter().map(|v| v.to_string_lossy().into_owned()).collect();
    let takes_value = !matches!(a.get_action(), ArgAction::SetTrue | ArgAction::SetFalse | ArgAction::Count);
    if takes_value && !defaults.is_empty() {
        m += &format!(" Default: `{}`.", defaults.join(" "));
    }
    let possible: Vec<String> =
        a.get_possible_values().iter().filter(|v| !v.is_hide_set()).map(|v| format!("`{}`", v.get_name())).collect();
    if takes_value && !possible.is_empty() {
        m += &format!(" One of {}.", possible.join(", "));
    }
    m.trim().to_string()
}

/// A help text's lines as one paragraph.
#[cfg(test)]
fn one_paragraph(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Text safe in a Markdown table cell.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

/// `<` and `>` outside code spans as entities: help texts say `reports/<name>`, which
/// Markdown would take for an HTML tag.
#[cfg(test)]
fn angles(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut code = false;
    for c in text.chars() {
        match c {
            '`' => {
                code = !code;
                out.push(c);
            }
            '<' if !code => out.push_str("&lt;"),
            '>' if !code => out.push_str("&gt;"),
            _ => out.push(c),
        }
    }
    out
}

/// `docs/src/reference/solvers.md` (and `mapbench list solvers --markdown`): the catalogue.
pub fn solvers_markdown() -> String {
    use solvers::tasks::catalogue::SOLVERS;
    let mut s = String::from(
        "# Solvers\n\n<!-- Generated from the solver catalogue: `mapbench list solvers --markdown`; a test fails \
         when it differs. -->\n\nThe catalogue (`solvers/src/tasks/catalogue/`), one row per solver: the tasks it \
         runs, the energies it is defined for, its family (`harness/src/family.rs`: the reports draw a family in related hues) and the \
         columns it adds to the per-iteration CSVs ([Columns](columns.md)).\n\n\
         | solver | tasks | energies | family | extra iteration columns | what it is |\n|---|---|---|---|---|---|\n",
    );
    for e in SOLVERS {
        let family = mapbench::family::family(e.name).map_or("", |f| f.label());
        let tasks: Vec<&str> = e.tasks.iter().map(|t| t.as_str()).collect();
        let columns: Vec<String> = e.extra_columns.iter().map(|c| format!("`{c}`")).collect();
        s += &format!(
            "| `{}` | {} | {} | {family} | {} | {} |\n",
            e.name,
            tasks.join(", "),
            cell(&e.energies.join(", ")),
            if columns.is_empty() { "".to_string() } else { columns.join(", ") },
            cell(e.description)
        );
    }
    s
}
