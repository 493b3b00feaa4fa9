//! rosbag2 sqlite3 bags (`.db3`, feature `db3`).

use super::*;
#[cfg(feature = "db3")]
use crate::io::replay::Location;
use crate::io::replay::ReplayError;
#[cfg(feature = "db3")]
use std::collections::HashMap;
use std::path::Path;

/// Without the `db3` feature (no SQLite compiled in): the error says how to get it.
#[cfg(not(feature = "db3"))]
pub fn read_db3(file: &Path) -> BagContents {
    BagContents {
        error: Some(ReplayError::Sqlite {
            file: file.to_path_buf(),
            after_row: None,
            reason: "this `lives` was built without sqlite3 bag support (rebuild with `--features db3`, or `ros-bags`)".into(),
        }),
        ..BagContents::default()
    }
}

/// Reads a rosbag2 sqlite3 file (`topics` and `messages` tables), rows in id order.
#[cfg(feature = "db3")]
pub fn read_db3(file: &Path) -> BagContents {
    let mut out = BagContents::default();
    let err =
        |after_row: Option<i64>, e: rusqlite::Error| ReplayError::Sqlite { file: file.to_path_buf(), after_row, reason: e.to_string() };
    let flags = rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY | rusqlite::OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let conn = match rusqlite::Connection::open_with_flags(file, flags) {
        Ok(c) => c,
        Err(e) => {
            out.error = Some(err(None, e));
            return out;
        }
    };
    // A truncated file claims more pages than it has, which sqlite refuses outright; with
    // `writable_schema` it reads the pages that are there (the connection stays read-only), so
    // the rows before the damage can still be replayed.
    if let Err(e) = conn.pragma_update(None, "writable_schema", "ON") {
        out.error = Some(err(None, e));
        return out;
    }
    let mut topics: HashMap<i64, (String, String, String)> = HashMap::new();
    let read_topics = || -> rusqlite::Result<Vec<(i64, String, String, String)>> {
        let mut st = conn.prepare("SELECT id, name, type, serialization_format FROM topics")?;
        let rows = st.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))?;
        rows.collect()
    };
    match read_topics() {
        Ok(rows) => {
            for (id, name, ty, fmt) in rows {
                if MsgType::of(&ty, &name).is_some() {
                    if fmt != "cdr" {
                        out.skipped_encodings.push(format!("{name} ({fmt})"));
                    } else {
                        out.topics.push((name.clone(), ty.clone()));
                    }
                }
                topics.insert(id, (name, ty, fmt));
            }
        }
        Err(e) => {
            out.error = Some(err(None, e));
            return out;
        }
    }
    let mut last_row = None;
    let mut read_messages = || -> rusqlite::Result<()> {
        let mut st = conn.prepare("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id")?;
        let mut rows = st.query([])?;
        let mut n = 0u64;
        // A row's boundaries are sqlite's: a column of the wrong type (a REAL topic id, a TEXT
        // time stamp) costs that row only. What stops reading is sqlite failing to step to the
        // next row (a damaged page).
        while let Some(r) = rows.next()? {
            n += 1;
            let row = || -> rusqlite::Result<(i64, i64, i64)> { Ok((r.get(0)?, r.get(1)?, r.get(2)?)) };
            let (id, topic_id, t) = match row() {
                Ok(v) => v,
                Err(e) => {
                    out.bad.add(ReplayError::SqliteRow { file: file.to_path_buf(), row: n, reason: e.to_string() });
                    continue;
                }
            };
            let t_ns = t.max(0) as u64;
            if let Some((name, ty, fmt)) = topics.get(&topic_id) {
                if let (Some(kind), "cdr") = (MsgType::of(ty, name), fmt.as_str()) {
                    let data: Vec<u8> = match r.get(3) {
                        Ok(d) => d,
                        Err(e) => {
                            out.bad.add(ReplayError::SqliteRow { file: file.to_path_buf(), row: n, reason: e.to_string() });
                            continue;
                        }
                    };
                    out.keep(BagMessage { t_ns, topic: name.clone(), kind, wire: Wire::Cdr, data, at: Location::Row(id) });
                }
            }
            out.saw(t_ns);
            last_row = Some(id);
        }
        Ok(())
    };
    if let Err(e) = read_messages() {
        out.error = Some(err(last_row, e));
    }
    out
}
