//! `sensor-replay eval` in one function: the accuracy of a solution (and
//! of a second one to compare) against the truth of its log, the figures,
//! and the review that needs no truth.
//!
//! The log and each solution are read once, together, in time order: a
//! truth record meets the row of its time as both stream in, and what the
//! statistics and figures need is kept as sums, envelopes and recent
//! windows in memory and as fixed-size records on disk ([`crate::spill`]).
//! Memory is bounded whatever the flight's length. This needs the
//! solutions' rows and the truth in increasing time, as `batch`, the
//! recorder and the simulator write them; a file that is not (a row that
//! repeats or goes back in time, an MCAP file whose messages are out of
//! order) is evaluated as before, every record in memory, with a note:
//! the results are the same either way.

use std::cell::RefCell;
use std::fmt::Write as _;
use std::path::Path;
use std::rc::Rc;

use msgs::navlog::Record;
use msgs::{PerAid, TruthRecord};
use polarnav::solution_csv::Row;

use crate::eval::{self, DeviationAcc, Epoch, SummaryAcc, TransientAcc, time_key, truth_key};
use crate::figures::{FigureFeed, sigma_components};
use crate::logfile::{self, LogReader};
use crate::plots::{self, Figure};
use crate::review::{self, Reviewer};
use crate::solution_file::{
    self, AID_WORDS, AidPoint, AidSink, Aids, SolutionItem, SolutionStream, UpdatesOnDisk,
    try_map_aids,
};
use crate::spill::Spill;

/// What to evaluate: the arguments of `sensor-replay eval`.
#[derive(Debug, Clone, Copy)]
pub struct Args<'a> {
    /// The navlog of the flight (its truth, IMU, status records, settings).
    pub log: &'a Path,
    /// The solution, CSV or MCAP.
    pub solution: &'a Path,
    /// A second solution judged against the truth too.
    pub compare: Option<&'a Path>,
    /// A reference solution the review draws the difference from.
    pub reference: Option<&'a Path>,
    /// Where summary.md's figures go.
    pub out: Option<&'a Path>,
}

/// Why eval stopped.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// An input that cannot be evaluated: a file missing, unreadable or
    /// malformed, or solutions that share no time with the truth (exit
    /// status 2). The message names the file and where.
    #[error("{0}")]
    Input(String),
    /// A figure or directory that could not be written (exit status 1).
    #[error("{0}")]
    Output(String),
}

/// The summary (markdown), and notes for the standard error: damage the
/// log reader skipped, a file evaluated in memory.
#[derive(Debug, Clone, Default)]
pub struct Evaluated {
    pub markdown: String,
    pub notes: Vec<String>,
}

/// Evaluates `args`: streamed when the files are in time order, in memory
/// otherwise (see the module's documentation).
pub fn run(args: &Args<'_>) -> Result<Evaluated, EvalError> {
    match streamed(args) {
        Ok(e) => Ok(e),
        Err(Stop::Eval(e)) => Err(e),
        Err(Stop::Unordered(why)) => {
            let mut e = in_memory(args)?;
            e.notes.insert(
                0,
                format!(
                    "eval: {why}: the flight is evaluated in memory (every record held), not streamed"
                ),
            );
            Ok(e)
        }
    }
}

/// Why the streamed evaluation stopped.
#[derive(Debug)]
enum Stop {
    /// A file is not in time order: evaluate it in memory.
    Unordered(String),
    Eval(EvalError),
}

impl From<EvalError> for Stop {
    fn from(e: EvalError) -> Self {
        Self::Eval(e)
    }
}

fn input(e: impl std::fmt::Display) -> Stop {
    Stop::Eval(EvalError::Input(e.to_string()))
}

fn output(e: impl std::fmt::Display) -> Stop {
    Stop::Eval(EvalError::Output(e.to_string()))
}

/// The scenario's name from the log's header.
fn scenario_name(header: Option<&msgs::navlog::Header>) -> String {
    header.map_or("solution".to_owned(), |h| h.scenario.clone())
}

/// The first section when the log has no truth.
fn no_truth_markdown(name: &str, args: &Args<'_>) -> String {
    let mut md = format!(
        "## {name}: no truth\n\n{} has no truth records (a live recording or an imported log): \
         no accuracy figures (position_errors, velocity_errors, attitude_errors, \
         horizontal_rmse and track compare with the truth; imu_biases with the true bias; \
         innovations and compare_difference are drawn with them). \
         The review below needs no truth.\n\n",
        args.log.display()
    );
    if args.compare.is_some() {
        md.push_str(
            "`--compare` judges both runs against the truth and was skipped: \
             use `--reference` to draw the difference of two runs without truth.\n\n",
        );
    }
    md
}

/// A run's accuracy and switch transients.
fn accuracy_markdown(
    name: &str,
    label: &str,
    path: &Path,
    s: &eval::Summary,
    transients: &[eval::SwitchTransient],
) -> String {
    let title = format!("Accuracy: {name} ({label}: {})", path.display());
    let mut md = eval::markdown(&title, s);
    md.push('\n');
    md.push_str(&eval::transients_markdown(label, transients));
    md.push('\n');
    md
}

/// The list of figures written.
fn figures_markdown(files: &[Figure], no_truth_bias: bool) -> String {
    let mut md = String::from("### Figures\n\n");
    for f in files {
        let n = f
            .path
            .file_name()
            .map_or_else(String::new, |x| x.to_string_lossy().into_owned());
        let _ = writeln!(md, "- `{n}`: {}\n\n  ![{n}]({n})", f.what);
    }
    if no_truth_bias {
        md.push_str(
            "- `imu_biases` shows the estimates only: the log has no truth-bias \
             records (logs simulated before navlog format 3, or imported)\n",
        );
    }
    md.push('\n');
    md
}

/// A run's name in the figures: its file name.
fn file_label(label: &str, path: &Path) -> String {
    path.file_name()
        .map_or_else(|| label.to_owned(), |f| f.to_string_lossy().into_owned())
}

fn no_epoch(path: &Path, log: &Path) -> EvalError {
    EvalError::Input(format!(
        "{}: no solution row matches a truth epoch of {}",
        path.display(),
        log.display()
    ))
}

/// The runs judged against the truth: the solution, and the comparison.
fn runs<'a>(args: &Args<'a>) -> impl Iterator<Item = (&'static str, &'a Path)> {
    std::iter::once(("solution", args.solution)).chain(args.compare.map(|p| ("compare", p)))
}

/// The same evaluation with every record in memory, as eval always did:
/// what [`run`] does with files not in time order, and what its streamed
/// reading is tested against.
pub fn in_memory(args: &Args<'_>) -> Result<Evaluated, EvalError> {
    let bad = |e: String| EvalError::Input(e);
    let c = logfile::load(args.log).map_err(|e| bad(e.to_string()))?;
    let mut notes = Vec::new();
    if !c.report.is_clean() {
        notes.push(format!("warning: {}: {}", args.log.display(), c.report));
    }
    let name = scenario_name(c.header.as_ref());
    let mut md = String::new();
    let mut loaded = Vec::new();
    let mut aids = None;
    let has_truth = !c.truth.is_empty();
    if !has_truth {
        md.push_str(&no_truth_markdown(&name, args));
    }
    for (label, path) in runs(args).filter(|_| has_truth) {
        let l = solution_file::load(path).map_err(bad)?;
        if label == "solution" {
            aids = l.aids;
        }
        let rows = l.rows;
        let ep = eval::epochs(&rows, &c.truth);
        if ep.is_empty() {
            return Err(no_epoch(path, args.log));
        }
        let s = eval::summarize(&rows, &ep);
        md.push_str(&accuracy_markdown(
            &name,
            label,
            path,
            &s,
            &eval::switch_transients(&rows, &ep, 60.0, 200.0),
        ));
        loaded.push((file_label(label, path), rows, ep));
    }
    if let Some(dir) = args.out.filter(|_| has_truth) {
        std::fs::create_dir_all(dir)
            .map_err(|e| EvalError::Output(format!("{}: {e}", dir.display())))?;
        let series: Vec<plots::Series<'_>> = loaded
            .iter()
            .map(|(l, r, e)| plots::Series {
                label: l,
                rows: r,
                epochs: e,
            })
            .collect();
        let files = plots::write_all(
            dir,
            &plots::Inputs {
                runs: &series,
                truth: &c.truth,
                truth_bias: &c.truth_bias,
                aids: aids.as_ref(),
            },
        )
        .map_err(|e| EvalError::Output(e.to_string()))?;
        md.push_str(&figures_markdown(&files, c.truth_bias.is_empty()));
    }
    if let [(_, a, _), (_, b, _)] = &loaded[..] {
        md.push_str(&eval::deviation_markdown(
            &eval::deviation_after_switches(a, b, 200.0),
            200.0,
        ));
    }
    let r = review::review(
        &c,
        &review::Options {
            solution: args.solution,
            reference: args.reference,
            out: args.out,
        },
    )
    .map_err(bad)?;
    md.push_str(&r.markdown);
    Ok(Evaluated {
        markdown: md,
        notes,
    })
}

/// The error of a solution without a single row, as reading it whole says.
fn empty_solution(path: &Path, has_truth: bool) -> Stop {
    input(if solution_file::is_mcap(path) {
        format!(
            "{}: no /solution message (write it with nav-daemon batch --out FILE.mcap)",
            path.display()
        )
    } else if has_truth {
        format!("{}: no solution row after the header", path.display())
    } else {
        format!("{}: no solution row", path.display())
    })
}

/// One solution read in time order, with what is judged of it.
struct Run<'a> {
    label: &'static str,
    path: &'a Path,
    stream: SolutionStream,
    /// The next row, not yet taken.
    head: Option<(Row, Option<[f64; 6]>)>,
    /// The last row taken, and how many.
    last: Option<Row>,
    rows: u64,
    summary: SummaryAcc,
    transients: TransientAcc,
    /// The aid updates of an MCAP solution, repeated ones dropped (see
    /// [`solution_file::load`]); `None` for a CSV solution or a run whose
    /// aids are not read.
    aids: Option<AidsIn>,
}

/// Aid updates as they come: on disk, with each aid's last one.
struct AidsIn {
    spills: Aids<Spill<AID_WORDS>>,
    last: PerAid<Option<AidPoint>>,
}

impl<'a> Run<'a> {
    fn open(label: &'static str, path: &'a Path, with_aids: bool) -> Result<Self, Stop> {
        let aids = if with_aids && solution_file::is_mcap(path) {
            Some(AidsIn {
                spills: try_map_aids(PerAid::from_fn(|_| Spill::new()), |s| s).map_err(input)?,
                last: PerAid::default(),
            })
        } else {
            None
        };
        let mut r = Self {
            label,
            path,
            stream: SolutionStream::open(path).map_err(input)?,
            head: None,
            last: None,
            rows: 0,
            summary: SummaryAcc::default(),
            transients: TransientAcc::new(60.0, 200.0),
            aids,
        };
        r.advance()?;
        Ok(r)
    }

    /// Reads up to the next row (the aid updates on the way are kept).
    fn advance(&mut self) -> Result<(), Stop> {
        self.head = None;
        while let Some(item) = self.stream.next_item().map_err(input)? {
            match item {
                SolutionItem::Row(row, sig) => {
                    self.head = Some((row, sig));
                    break;
                }
                SolutionItem::Aid(kind, p) => {
                    let Some(a) = self.aids.as_mut() else {
                        continue;
                    };
                    let (spill, last) = (&mut a.spills[kind], &mut a.last[kind]);
                    if let Some(l) = last {
                        if p.t_ns < l.t_ns {
                            return Err(Stop::Unordered(format!(
                                "{}: the {} update at t = {} ns comes after one at {} ns",
                                self.path.display(),
                                kind.decl().update_topic,
                                p.t_ns,
                                l.t_ns
                            )));
                        }
                        // Recordings' repeated updates (see solution_file::load).
                        if p.same_update(l) {
                            continue;
                        }
                    }
                    *last = Some(p);
                    spill.put(p).map_err(input)?;
                }
            }
        }
        Ok(())
    }

    fn head_key(&self) -> Option<i64> {
        self.head.as_ref().map(|(r, _)| time_key(r.t_s))
    }

    /// Takes the head row, checking that it follows the one before:
    /// later by more than 0.1 µs and in a later microsecond (`strict`, to
    /// be matched with the truth), or not earlier.
    fn take(&mut self, strict: bool) -> Result<(Row, Option<[f64; 6]>), Stop> {
        let Some((row, sig)) = self.head.take() else {
            return Err(input("internal: no row to take"));
        };
        self.rows += 1;
        let follows = match &self.last {
            _ if !row.t_s.is_finite() => false,
            None => true,
            Some(p) if strict => row.t_s > p.t_s + 1e-7 && time_key(row.t_s) > time_key(p.t_s),
            Some(p) => row.t_s >= p.t_s,
        };
        if !follows {
            return Err(Stop::Unordered(format!(
                "{}: row {} (t = {} s) does not follow the row before it (t = {} s){}",
                self.path.display(),
                self.rows,
                row.t_s,
                self.last.map_or(f64::NAN, |p| p.t_s),
                if strict { " by more than 0.1 µs" } else { "" }
            )));
        }
        self.advance()?;
        Ok((row, sig))
    }

    /// The last row taken, if it is at the time of `key`.
    fn at(&self, key: i64) -> Option<&Row> {
        self.last.as_ref().filter(|r| time_key(r.t_s) == key)
    }

    fn sealed_aids(&mut self) -> Result<Option<Aids<UpdatesOnDisk>>, Stop> {
        match self.aids.take() {
            Some(a) => Ok(Some(try_map_aids(a.spills, Spill::seal).map_err(input)?)),
            None => Ok(None),
        }
    }
}

/// What the log gave besides its truth.
#[derive(Debug, Default)]
struct LogSeen {
    header: Option<msgs::navlog::Header>,
    truth_bias: u64,
}

/// Reads the log up to its next truth record, handing the records on the
/// way to the review and the figures.
fn next_truth(
    log: &mut LogReader,
    review: &mut Reviewer<'_>,
    feed: Option<&mut FigureFeed>,
    seen: &mut LogSeen,
) -> Result<Option<TruthRecord>, Stop> {
    let mut feed = feed;
    while let Some(r) = log.next_record().map_err(input)? {
        match &r {
            Record::Truth(t) => return Ok(Some(*t)),
            Record::TruthBias(b) => {
                seen.truth_bias += 1;
                if let Some(f) = feed.as_deref_mut() {
                    f.truth_bias(b).map_err(input)?;
                }
            }
            Record::Header(h) => seen.header = Some((**h).clone()),
            _ => {}
        }
        review.log_record(&r).map_err(input)?;
    }
    Ok(None)
}

/// The rows of a reference solution in file order; an MCAP file's must
/// not go back in time (reading it whole sorts them), which is noted in
/// `unordered` (and ends the rows).
fn reference_rows(
    path: &Path,
    unordered: Rc<RefCell<Option<String>>>,
) -> Result<review::RowIter, Stop> {
    let mut stream = SolutionStream::open(path).map_err(input)?;
    let sorted = solution_file::is_mcap(path);
    let p = path.display().to_string();
    let mut last = f64::NEG_INFINITY;
    let mut n = 0u64;
    Ok(Box::new(std::iter::from_fn(move || {
        loop {
            match stream.next_item() {
                Err(e) => return Some(Err(e)),
                Ok(None) => return None,
                Ok(Some(SolutionItem::Aid(..))) => {}
                Ok(Some(SolutionItem::Row(row, sig))) => {
                    n += 1;
                    if sorted && row.t_s.total_cmp(&last).is_lt() {
                        *unordered.borrow_mut() = Some(format!(
                            "{p}: row {n} (t = {} s) goes back from t = {last} s",
                            row.t_s
                        ));
                        return None;
                    }
                    last = row.t_s;
                    return Some(Ok((row, sig)));
                }
            }
        }
    })))
}

/// One pass over the log and the solutions together (see the module's
/// documentation); `Stop::Unordered` for a file not in time order.
fn streamed(args: &Args<'_>) -> Result<Evaluated, Stop> {
    let mut log = LogReader::open(args.log).map_err(input)?;
    let unordered = Rc::new(RefCell::new(None));
    let reference = match args.reference {
        Some(p) => Some(reference_rows(p, Rc::clone(&unordered))?),
        None => None,
    };
    let opts = review::Options {
        solution: args.solution,
        reference: args.reference,
        out: args.out,
    };
    let mut review = Reviewer::new(opts, reference, true).map_err(input)?;
    let labels: Vec<String> = runs(args).map(|(l, p)| file_label(l, p)).collect();
    let mut feed = match args.out {
        Some(_) => {
            let l: Vec<&str> = labels.iter().map(String::as_str).collect();
            Some(FigureFeed::new(&l).map_err(input)?)
        }
        None => None,
    };
    let mut seen = LogSeen::default();
    // The log up to its first truth record: whether it has any decides
    // what is judged.
    let mut truth = next_truth(&mut log, &mut review, feed.as_mut(), &mut seen)?;
    let has_truth = truth.is_some();
    if !has_truth {
        feed = None;
    }
    let mut a = Run::open("solution", args.solution, true)?;
    let mut b = match args.compare.filter(|_| has_truth) {
        Some(p) => Some(Run::open("compare", p, false)?),
        None => None,
    };
    let mut deviation = b.as_ref().map(|_| DeviationAcc::new(200.0));
    let mut last_truth: Option<i64> = None;
    loop {
        let never = i64::MAX;
        let (ka, kb, kt) = (
            a.head_key(),
            b.as_ref().and_then(Run::head_key),
            truth.as_ref().map(truth_key),
        );
        // In time order; at one time the comparison's row, then the
        // solution's, then the truth they are judged against.
        if let Some(kb) = kb
            && kb <= ka.unwrap_or(never)
            && kb <= kt.unwrap_or(never)
            && let Some(run) = b.as_mut()
        {
            let (row, _) = run.take(true)?;
            run.summary.row(&row);
            run.transients.row(&row);
            if let Some(f) = feed.as_mut() {
                f.row(1, &row).map_err(input)?;
            }
            run.last = Some(row);
        } else if let Some(k) = ka
            && k <= kt.unwrap_or(never)
        {
            let (row, sig) = a.take(has_truth)?;
            review.row(row, sig).map_err(input)?;
            if has_truth {
                a.summary.row(&row);
                a.transients.row(&row);
                if let Some(f) = feed.as_mut() {
                    f.row(0, &row).map_err(input)?;
                }
                if let Some(d) = deviation.as_mut() {
                    d.row(&row, b.as_ref().and_then(|b| b.at(k)));
                }
            }
            a.last = Some(row);
        } else if let Some(t) = truth.take() {
            let k = truth_key(&t);
            if last_truth.is_some_and(|l| k <= l) {
                return Err(Stop::Unordered(format!(
                    "{}: the truth record at t = {} ns is not in a later microsecond than the one before it",
                    args.log.display(),
                    t.t_ns
                )));
            }
            last_truth = Some(k);
            if let Some(f) = feed.as_mut() {
                f.truth(&t).map_err(input)?;
            }
            let mut at: [Option<Epoch>; 2] = [None, None];
            for (i, run) in std::iter::once(&mut a).chain(b.as_mut()).enumerate() {
                let Some(row) = run.at(k).copied() else {
                    continue;
                };
                let e = eval::epoch_of(&row, &t);
                run.summary.epoch(&e, &row.sigma_enu_m);
                run.transients.epoch(&e);
                if let Some(f) = feed.as_mut() {
                    f.epoch(i, &e).map_err(input)?;
                    if i == 0 {
                        f.band(e.t_s, &sigma_components(&row)).map_err(input)?;
                    }
                }
                at[i] = Some(e);
            }
            if let (Some(f), [Some(ea), Some(eb)]) = (feed.as_mut(), &at) {
                f.pair(ea, eb).map_err(input)?;
            }
            truth = next_truth(&mut log, &mut review, feed.as_mut(), &mut seen)?;
        } else {
            break;
        }
    }
    let mut notes = Vec::new();
    if !log.report().is_clean() {
        notes.push(format!("warning: {}: {}", args.log.display(), log.report()));
    }
    let name = scenario_name(seen.header.as_ref());
    let mut md = String::new();
    if !has_truth {
        md.push_str(&no_truth_markdown(&name, args));
    }
    for run in std::iter::once(&mut a).chain(b.as_mut()) {
        if !has_truth {
            break;
        }
        if run.rows == 0 {
            return Err(empty_solution(run.path, true));
        }
        let s = run.summary.summary();
        if s.epochs == 0 {
            return Err(no_epoch(run.path, args.log).into());
        }
        let transients = std::mem::replace(&mut run.transients, TransientAcc::new(0.0, 0.0));
        md.push_str(&accuracy_markdown(
            &name,
            run.label,
            run.path,
            &s,
            &transients.finish(),
        ));
    }
    if a.rows == 0 {
        return Err(empty_solution(a.path, has_truth));
    }
    let aids = a.sealed_aids()?;
    if let (Some(dir), Some(f)) = (args.out, feed) {
        std::fs::create_dir_all(dir).map_err(|e| output(format!("{}: {e}", dir.display())))?;
        let data = f.finish(aids.clone()).map_err(input)?;
        let files = plots::write_figures(dir, &data).map_err(output)?;
        md.push_str(&figures_markdown(&files, seen.truth_bias == 0));
    }
    if let Some(d) = deviation {
        md.push_str(&eval::deviation_markdown(&d.finish(), 200.0));
    }
    let r = review.finish(aids);
    if let Some(why) = unordered.borrow_mut().take() {
        return Err(Stop::Unordered(why));
    }
    md.push_str(&r.map_err(input)?.markdown);
    Ok(Evaluated {
        markdown: md,
        notes,
    })
}
