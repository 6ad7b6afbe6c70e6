//! Dates as the pages and the command line show them: UTC, from Unix seconds (civil-from-days,
//! no date crate needed).

/// Unix seconds as `YYYY-MM-DD hh:mm:ss UTC` (civil-from-days, no date crate needed).
pub fn utc(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// Unix seconds as `YYYY-MM-DD` (UTC).
pub fn utc_date(secs: u64) -> String {
    utc(secs)[..10].to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_from_unix_seconds() {
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        // as `date -u -d @1796488097` prints it
        assert_eq!(utc(1_796_488_097), "2026-12-05 16:28:17 UTC");
        assert_eq!(utc_date(1_796_488_097), "2026-12-05");
    }
}
