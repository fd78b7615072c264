//! The summary as the user reads it: one labelled line per aspect of the run (README.md,
//! "Reading the summary", explains each), counts in words and time steps as people write them. It
//! owns every number format the user sees in the summary, so a change here changes what users and
//! the README quote. It derives only presentation (shares, ratios, plurals) from the `Summary` as
//! built, and never reads a world or the frames.

use super::summary::{KindCount, Summary};
use std::fmt;
use vadop::memory::format_bytes;
use vadop::shape::ShapeKind;

/// `count` bodies of `kind`, as a reader says it: "1 cone", "3 convex hulls".
fn counted(count: usize, kind: &str) -> String {
    let plural = ShapeKind::ALL.iter().map(|k| k.words()).find(|(one, _)| *one == kind).map_or(kind, |(_, many)| many);
    number(count as u64, kind, plural)
}

/// `count` things, singular or plural: "1 contact", "0 contacts".
pub fn number(count: u64, one: &str, many: &str) -> String {
    format!("{count} {}", if count == 1 { one } else { many })
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let run = &self.run;
        let scene = &run.scene;
        let [x, y, z] = scene.extent;
        let mut shape =
            if x == y && y == z { format!("cube of side {x:.4}") } else { format!("box {x:.4} x {y:.4} x {z:.4}") };
        let periodic: String = scene.periodic.iter().zip("xyz".chars()).filter(|(p, _)| **p).map(|(_, a)| a).collect();
        if !periodic.is_empty() {
            shape.push_str(&format!(" (periodic in {periodic})"));
        }
        writeln!(f, "scene       {}", scene.source)?;
        let bodies = format!("{} {}", scene.bodies, if scene.bodies == 1 { "body" } else { "bodies" });
        if scene.may_spin() {
            let listed =
                |kinds: &[KindCount]| kinds.iter().map(|k| counted(k.count, &k.kind)).collect::<Vec<_>>().join(", ");
            let fixed: usize = scene.static_bodies.iter().map(|k| k.count).sum();
            let fixed = match fixed {
                0 => String::new(),
                n => format!(
                    " and {} ({})",
                    number(n as u64, "static body", "static bodies"),
                    listed(&scene.static_bodies)
                ),
            };
            writeln!(f, "            {bodies} ({}){fixed}", listed(&scene.kinds))?;
            writeln!(
                f,
                "            {shape}, packing {:.4}, max speed {:.4} diameters/frame (fastest body; a shape's diameter is its bounding sphere's), max spin {:.4} rad/frame",
                scene.packing, scene.max_speed, scene.max_spin
            )?;
        } else {
            writeln!(
                f,
                "            {bodies}, {shape}, packing {:.4}, max speed {:.4} diameters/frame (fastest body)",
                scene.packing, scene.max_speed
            )?;
        }
        let friction = if run.friction > 0.0 { format!(", friction {}", run.friction) } else { String::new() };
        writeln!(
            f,
            "method      {}, {} mode, dt {}, restitution {}{friction}",
            run.method,
            run.mode,
            seconds(run.dt),
            run.restitution
        )?;
        // The default is the fastest method, not the paper's: say how to run that one.
        if run.method.starts_with("auto") {
            writeln!(f, "            the default, the fastest method here; --method vadop runs the paper's VADOP sweep and prune")?;
        }
        match &self.pool {
            Some(p) => writeln!(
                f,
                "pool        m = {} axes, rho = {:.4} deg, phi = {:.4} deg, {:.2} axes per body (mean over the frames that start a window)",
                p.axes, p.covering_radius_deg, p.phi_deg, p.axes_per_body
            )?,
            None => writeln!(f, "pool        none ({} uses no axis pool)", run.method)?,
        }
        writeln!(
            f,
            "frames      {} of {} ({:.4} s simulated)",
            self.frames_completed, run.frames_requested, self.simulated_seconds
        )?;
        let c = &self.contacts;
        let statics = if c.statics > 0 || !scene.static_bodies.is_empty() {
            format!(", {} with static bodies", c.statics)
        } else {
            String::new()
        };
        writeln!(
            f,
            "contacts    {} ({}{statics}, {} with walls), {:.1} per frame, {:.0} per wall-clock second{}",
            c.total,
            number(c.pairs, "body pair", "body pairs"),
            c.walls,
            self.per_frame.contacts,
            c.per_wall_second,
            if c.ends > 0 {
                format!("; {} between bodies ended", number(c.ends, "contact", "contacts"))
            } else {
                String::new()
            }
        )?;
        match &self.accuracy {
            Some(a) => {
                let label = if a.identical_paths {
                    "detect mode: identical paths, so these are exact misses".to_string()
                } else {
                    match a.first_difference_frame {
                        Some(frame) => format!(
                            "simulate mode: paths diverge from frame {frame} on, so later differences are not misses"
                        ),
                        None => "simulate mode: paths never diverged".to_string(),
                    }
                };
                writeln!(
                    f,
                    "accuracy    vs {}: {} missed, {} extra of {} ({label})",
                    a.reference,
                    a.missed,
                    a.extra,
                    number(a.reference_pairs, "reference pair contact", "reference pair contacts")
                )?
            }
            None => writeln!(f, "accuracy    not checked (no reference method)")?,
        }
        let (t, w) = (&self.c_total_ms, &self.wall_ms);
        writeln!(f, "ms/frame    c_total    median {:.3}, mean {:.3}, p95 {:.3}", t.median, t.mean, t.p95)?;
        writeln!(f, "            wall-clock median {:.3}, mean {:.3}, p95 {:.3}", w.median, w.mean, w.p95)?;
        let s = &self.cost_split;
        let sum = s.update_ms + s.sort_ms + s.test_ms + s.response_ms;
        let share = |ms: f64| if sum > 0.0 { 100.0 * ms / sum } else { 0.0 };
        writeln!(
            f,
            "cost split  update {:.3} ms ({:.1}%), sort {:.3} ms ({:.1}%), test {:.3} ms ({:.1}%), response {:.3} ms ({:.1}%)",
            s.update_ms,
            share(s.update_ms),
            s.sort_ms,
            share(s.sort_ms),
            s.test_ms,
            share(s.test_ms),
            s.response_ms,
            share(s.response_ms)
        )?;
        let p = &self.per_frame;
        writeln!(
            f,
            "per frame   {:.2} broad-phase windows, {:.1} endpoint swaps, {:.1} candidate pairs, {:.1} narrow tests, {:.1} re-tests, {:.1} invalidations",
            p.windows, p.endpoint_swaps, p.candidate_pairs, p.narrow_tests, p.retests, p.invalidations
        )?;
        let r = &self.rules;
        let rest = match &self.resting {
            Some(_) => format!(", {} by the rest rule", r.rest_contacts),
            None => String::new(),
        };
        writeln!(
            f,
            "rules       {} made elastic by the TC model, {} resolved by the jam rule{rest}{}",
            number(r.tc_contacts, "contact", "contacts"),
            r.jam_contacts,
            if r.tc_contacts + r.jam_contacts + r.rest_contacts == 0 { " (the physics was never changed)" } else { "" }
        )?;
        if let Some(resting) = &self.resting {
            writeln!(
                f,
                "at rest     {} of {} bodies lie still, {} slide along the walls gravity presses them into (the rest rule)",
                resting.still, resting.bodies, resting.sliding
            )?;
        }
        let peak = match self.peak_memory_mib {
            Some(mib) if self.accuracy.is_some() => format!("{mib:.1} MiB (whole process, reference world included)"),
            Some(mib) => format!("{mib:.1} MiB (whole process)"),
            None => "unknown (no /proc/self/status)".to_string(),
        };
        writeln!(f, "memory      broad phase {}, peak {peak}", format_bytes(self.broad_phase_bytes))?;
        if let Some(c) = &self.conservation {
            // Spins are in the totals whenever bodies spin; say so when they do.
            let (spin, angular, exchanged) = match c.angular_momentum_change {
                Some(change) => (
                    " (translation and spin)",
                    format!("; angular momentum change {change:.3e} (about the origin, orbits and spins)"),
                    " and angular momentum",
                ),
                None => ("", String::new(), ""),
            };
            // Only an elastic, frictionless run should keep its energy: elsewhere the change is
            // the loss the run was asked for.
            let mut losses = Vec::new();
            if run.restitution < 1.0 {
                losses.push(format!("restitution {}", run.restitution));
            }
            if run.friction > 0.0 {
                losses.push(format!("friction {}", run.friction));
            }
            // Under gravity the energy kept is the kinetic plus the potential.
            let spin = if run.has_gravity() { format!("{spin} plus potential") } else { spin.to_string() };
            let energy = match c.kinetic_relative_drift {
                None => "kinetic energy n/a (nothing moves)".to_string(),
                Some(drift) if losses.is_empty() => {
                    format!(
                        "kinetic energy{spin} relative drift {drift:+.3e} (elastic and frictionless: 0 up to rounding)"
                    )
                }
                Some(change) => {
                    format!(
                        "kinetic energy{spin} relative change {change:+.3e} (a loss by design: {})",
                        losses.join(", ")
                    )
                }
            };
            let scale = if c.momentum_sum > 0.0 {
                format!(" ({:.3e} of the bodies' sum of |m v| at the start)", c.momentum_change / c.momentum_sum)
            } else {
                String::new()
            };
            let statics = if scene.static_bodies.is_empty() { "" } else { " and static bodies" };
            let why = if scene.periodic == [true; 3] && statics.is_empty() && !run.has_gravity() {
                "a periodic box has no walls: 0 up to rounding".to_string()
            } else {
                format!("walls{statics} exchange momentum{exchanged} with the bodies")
            };
            writeln!(f, "energy      {energy}; momentum change {:.3e}{scale}{angular} ({why})", c.momentum_change)?;
        }
        if let Some(p) = &self.pressure {
            writeln!(
                f,
                "pressure    Z = PV/NkT = {:.6} from the collisional virial of {} impacts between moving bodies",
                p.z, p.impacts
            )?;
        }
        if let Some(error) = &self.error {
            writeln!(f, "stopped     {error}")?;
        }
        Ok(())
    }
}

/// A time step as a reader wants it: `1/30 s` for a whole fraction of a second (the frame rates
/// people choose), otherwise six significant digits.
fn seconds(dt: f64) -> String {
    let rate = 1.0 / dt;
    if (2.0..1e9).contains(&rate) && (rate - rate.round()).abs() <= 1e-9 * rate {
        format!("1/{} s", rate.round())
    } else {
        let rounded: f64 = format!("{dt:.5e}").parse().unwrap_or(dt);
        if (1e-4..1e6).contains(&rounded) {
            format!("{rounded} s")
        } else {
            format!("{rounded:e} s")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_steps_read_as_people_write_them() {
        assert_eq!(seconds(1.0 / 30.0), "1/30 s");
        assert_eq!(seconds(0.16666666666666666), "1/6 s");
        assert_eq!(seconds(0.25), "1/4 s");
        assert_eq!(seconds(0.123456789), "0.123457 s");
        assert_eq!(seconds(3.0), "3 s");
        assert_eq!(seconds(1e-300), "1e-300 s");
        assert_eq!(seconds(2.5e7), "2.5e7 s");
    }
}
