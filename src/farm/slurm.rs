//! The farm plan as a Slurm submission script: run on a login node, it submits a job array per
//! step (`rings` when the shot's rings are generated, one task per frame; `render`, one task per
//! frame and sample chunk; `merge`, one task per frame), each held with
//! `--dependency=afterok:` until the step before it has succeeded whole. Render tasks are
//! requeued when preempted and get SIGTERM two minutes before their time limit: rift saves its
//! checkpoint, and the requeued task resumes from it.

use super::{Arg, Piece, Plan, SlurmArgs};
use anyhow::bail;

/// Seconds before a task's time limit at which Slurm asks it to stop.
const NOTIFY_SECONDS: u32 = 120;

/// The submission script's text.
pub fn script(plan: &Plan, args: &SlurmArgs) -> anyhow::Result<String> {
    for (name, value) in [
        ("--partition", args.partition.as_deref()),
        ("--time", args.time.as_deref()),
    ] {
        if let Some(v) = value
            && (v.is_empty()
                || !v
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_:.,".contains(c)))
        {
            bail!("{name}: {v:?} is not a Slurm {}", &name[2..]);
        }
    }
    let frames: Vec<i64> = plan.frames.iter().collect();
    let tasks: Vec<(i64, &str)> = frames
        .iter()
        .flat_map(|&f| plan.chunks.iter().map(move |c| (f, c.as_str())))
        .collect();
    let mut options = String::new();
    if let Some(p) = &args.partition {
        options.push_str(&format!(" --partition={p}"));
    }
    let mut out = format!(
        "#!/bin/bash\n\
         # Slurm submission for shot {shot} (rift farm slurm): run it where sbatch works.\n\
         # Steps: {steps}render ({n_tasks} tasks: {n_frames} frame(s) x {n_chunks} sample chunk(s)), merge.\n\
         set -euo pipefail\n\
         WORK={work}\n\
         mkdir -p \"$WORK/logs\" \"$WORK/parts\"\n\
         # sbatch --parsable prints `id` or `id;cluster`.\n\
         submit() {{ local id; id=$(sbatch --parsable \"$@\"); echo \"${{id%%;*}}\"; }}\n",
        shot = plan.shot_name,
        steps = if plan.bake_rings { "rings, " } else { "" },
        n_tasks = tasks.len(),
        n_frames = frames.len(),
        n_chunks = plan.chunks.len(),
        work = quote(&plan.work_dir),
    );
    let frame_list = frames.iter().map(i64::to_string).collect::<Vec<_>>();
    let mut after = String::new();
    if plan.bake_rings {
        out.push_str(&submission(
            "rings",
            plan,
            &options,
            &after,
            &[("FRAME", frame_list.clone())],
            &plan.fx_args(),
        ));
        after = " --dependency=afterok:$rings".into();
    }
    let mut render_options = format!("{options} --requeue --signal=B:TERM@{NOTIFY_SECONDS}");
    if let Some(n) = args.cpus_per_task {
        render_options.push_str(&format!(" --cpus-per-task={n}"));
    }
    if let Some(t) = &args.time {
        render_options.push_str(&format!(" --time={t}"));
    }
    out.push_str(&submission(
        "render",
        plan,
        &render_options,
        &after,
        &[
            ("FRAME", tasks.iter().map(|t| t.0.to_string()).collect()),
            ("SAMPLES", tasks.iter().map(|t| t.1.to_owned()).collect()),
        ],
        &plan.render_args(),
    ));
    out.push_str(&submission(
        "merge",
        plan,
        &options,
        " --dependency=afterok:$render",
        &[("FRAME", frame_list)],
        &plan.merge_args(),
    ));
    out.push_str(&format!(
        "echo \"rift farm: submitted{} render $render, merge $merge; logs in $WORK/logs\"\n",
        if plan.bake_rings {
            " rings $rings,"
        } else {
            ""
        }
    ));
    Ok(out)
}

/// `NAME=$(submit … <<'EOF' … EOF)`: a job array whose task i takes the i-th value of each of
/// `lists` and runs rift with `args`.
fn submission(
    name: &str,
    plan: &Plan,
    options: &str,
    after: &str,
    lists: &[(&str, Vec<String>)],
    args: &[Arg],
) -> String {
    let count = lists[0].1.len();
    let mut body = String::from("#!/bin/bash\nset -euo pipefail\n");
    for (var, values) in lists {
        let values: Vec<String> = values.iter().map(|v| quote(v)).collect();
        body.push_str(&format!("{var}_LIST=({})\n", values.join(" ")));
        body.push_str(&format!("{var}=${{{var}_LIST[$SLURM_ARRAY_TASK_ID]}}\n"));
    }
    let words: Vec<String> = args.iter().map(|a| word(plan, a)).collect();
    body.push_str(&format!("exec {} {}\n", quote(&plan.rift), words.join(" ")));
    format!(
        "{name}=$(submit --job-name=rift-{name}-{shot} --array=0-{last}{after}{options} \\\n    \
         --output=\"$WORK/logs/{name}-%A_%a.log\" --open-mode=append <<'EOF'\n{body}EOF\n)\n",
        shot = plan.shot_name,
        last = count - 1,
    )
}

/// An argument as one shell word: text single-quoted, task values as quoted variables.
fn word(plan: &Plan, arg: &[Piece]) -> String {
    arg.iter()
        .map(|piece| match piece {
            Piece::Text(t) => quote(t),
            Piece::Rift => quote(&plan.rift),
            Piece::ShotFile => quote(&plan.shot_file),
            Piece::Output => quote(&plan.output),
            Piece::WorkDir => quote(&plan.work_dir),
            Piece::Frame => "\"$FRAME\"".into(),
            Piece::Samples => "\"$SAMPLES\"".into(),
        })
        .collect()
}

/// A single-quoted shell word (a quote inside becomes '\'').
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    use super::quote;

    #[test]
    fn quoting_survives_quotes() {
        assert_eq!(quote("a b"), "'a b'");
        assert_eq!(quote("it's"), "'it'\\''s'");
    }
}
