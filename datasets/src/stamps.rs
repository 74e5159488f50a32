//! Which clock places a log's messages in time.
//!
//! Three of the readers see two clocks per message: a ROS bag (the header stamp the
//! driver wrote, and the record time the recorder wrote), a leigh-gtm1 text export of
//! such a bag (`stamp_header_s`, `stamp_bag_s`) and a CARMEN log (`ipc_timestamp`, the
//! sender's, and `logger_timestamp`, the logger's). Header stamps are the better clock
//! (the moment the sensor measured, without the transport's delay), and the one that
//! ROS tooling (tf, message_filters) interpolates by; but drivers write zero stamps
//! (unset), repeat a stamp, or step back after a clock adjustment, while the recorder's
//! clock still increases. Used as they are, such stamps interpolate odometry and
//! motion-capture truth at the wrong moments and break a sequence into false pieces.
//!
//! Every such reader follows one rule, [`StampClock`]:
//! - [`StampClock::Auto`] (the default): header stamps when every stream read (each
//!   topic; CARMEN's laser and `ODOM` lines) has header stamps that are positive and
//!   strictly increasing in record order; otherwise the record times for **every**
//!   stream (one clock for all, so that interpolation never mixes clocks), with a note
//!   naming the stream, how many stamps are at fault and the first. Where the record
//!   times are not increasing either (a CARMEN log has no recorder that orders it), the
//!   header stamps are kept in file order, with the note.
//! - [`StampClock::Header`]: header stamps; a fault is an error naming the message.
//! - [`StampClock::Record`]: record times, whatever the header stamps are.
//!
//! A fault is a stamp `<= 0` (unset), one equal to the previous message's stamp, or one
//! before it ([`stamp_faults`]).

use std::fmt;
use std::str::FromStr;

/// Which clock places messages in time (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum StampClock {
    /// Header stamps unless one stream's are at fault, then record times for all.
    #[default]
    Auto,
    /// Header stamps; a zero, repeated or backward stamp is an error.
    Header,
    /// Record times (the recorder's or logger's clock).
    Record,
}

impl StampClock {
    /// The names `auto`, `header`, `record`.
    pub const NAMES: [&'static str; 3] = ["auto", "header", "record"];
}

impl fmt::Display for StampClock {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StampClock::Auto => "auto",
            StampClock::Header => "header",
            StampClock::Record => "record",
        })
    }
}

impl FromStr for StampClock {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "auto" => Ok(StampClock::Auto),
            "header" => Ok(StampClock::Header),
            "record" => Ok(StampClock::Record),
            other => Err(format!(
                "{other:?}: expected one of {} (which clock places messages in time)",
                StampClock::NAMES.join(", ")
            )),
        }
    }
}

/// A header stamp at fault, by its position in record order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StampFault {
    /// Position of the message in record order (from 0).
    pub at: usize,
    /// Its stamp (s).
    pub stamp: f64,
    /// The previous message's stamp (s), if any.
    pub previous: Option<f64>,
}

impl fmt::Display for StampFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.previous {
            _ if self.stamp <= 0.0 => write!(f, "stamp {} s is unset (not after 0)", self.stamp),
            Some(p) if self.stamp == p => write!(f, "stamp {} s repeats the previous one", p),
            Some(p) => write!(
                f,
                "stamp {} s goes back from the previous {p} s",
                self.stamp
            ),
            None => write!(f, "stamp {} s", self.stamp),
        }
    }
}

/// The faults of one stream of header stamps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StampFaults {
    /// How many stamps are at fault.
    pub count: usize,
    /// How many stamps the stream has.
    pub total: usize,
    /// The first fault.
    pub first: StampFault,
}

/// The faults of `stamps`, given in record order (module docs), or `None` when every
/// stamp is positive and after the previous one.
pub fn stamp_faults(stamps: impl IntoIterator<Item = f64>) -> Option<StampFaults> {
    let mut first = None;
    let mut count = 0;
    let mut total = 0;
    let mut previous: Option<f64> = None;
    for (at, stamp) in stamps.into_iter().enumerate() {
        total += 1;
        let fault = stamp <= 0.0 || previous.is_some_and(|p| stamp <= p);
        if fault {
            count += 1;
            first.get_or_insert(StampFault {
                at,
                stamp,
                previous,
            });
        }
        previous = Some(stamp);
    }
    first.map(|first| StampFaults {
        count,
        total,
        first,
    })
}

/// Whether `times` never decrease (record times may repeat: two topics written at the
/// same moment).
pub fn non_decreasing(times: impl IntoIterator<Item = f64>) -> bool {
    let mut previous = f64::NEG_INFINITY;
    times.into_iter().all(|t| {
        let ok = t >= previous;
        previous = t;
        ok
    })
}

/// The clock a reader uses (module docs), given the rule, whether any stream's header
/// stamps are at fault, and whether the record times can order the messages.
pub fn chosen(rule: StampClock, header_faults: bool, record_usable: bool) -> StampClock {
    match rule {
        StampClock::Auto if header_faults && record_usable => StampClock::Record,
        StampClock::Auto => StampClock::Header,
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_are_zero_repeated_and_backward_stamps() {
        assert_eq!(stamp_faults([1.0, 2.0, 3.0]), None);
        assert_eq!(stamp_faults(std::iter::empty()), None);
        let f = stamp_faults([1.0, 2.0, 2.0, 1.5, 0.0, 5.0]).unwrap();
        assert_eq!((f.count, f.total), (3, 6));
        assert_eq!(f.first.at, 2);
        assert_eq!(f.first.to_string(), "stamp 2 s repeats the previous one");
        let back = stamp_faults([3.0, 1.0]).unwrap().first;
        assert_eq!(
            back.to_string(),
            "stamp 1 s goes back from the previous 3 s"
        );
        let zero = stamp_faults([0.0, 1.0]).unwrap();
        assert_eq!((zero.count, zero.first.at), (1, 0));
        assert_eq!(zero.first.to_string(), "stamp 0 s is unset (not after 0)");
    }

    #[test]
    fn the_rule_chooses_record_times_only_when_they_can_order() {
        use StampClock::*;
        assert_eq!(chosen(Auto, false, true), Header);
        assert_eq!(chosen(Auto, true, true), Record);
        assert_eq!(chosen(Auto, true, false), Header);
        assert_eq!(chosen(Header, true, true), Header);
        assert_eq!(chosen(Record, false, false), Record);
        assert!(non_decreasing([1.0, 1.0, 2.0]));
        assert!(!non_decreasing([1.0, 0.5]));
        for name in StampClock::NAMES {
            assert_eq!(name.parse::<StampClock>().unwrap().to_string(), name);
        }
        assert!("Header"
            .parse::<StampClock>()
            .unwrap_err()
            .contains("auto, header"));
    }
}
