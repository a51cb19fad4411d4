//! Reading input files within bounds. Shots, meshes, caches and maps come from other tools and
//! other people; a path that names a directory, a device, a FIFO or an endless file must get a
//! clear error at once, not a read that never ends or fills memory.

use std::io::{self, Read};
use std::path::Path;

/// The largest input file rift reads, in bytes (a mesh of hundreds of millions of triangles
/// fits; anything larger is more likely a wrong path than a scene).
pub const MAX_INPUT_BYTES: u64 = 16 << 30;

/// The size of `path` when it is a regular file rift may read whole; an error naming what it
/// is otherwise.
pub fn regular_file(path: &Path) -> io::Result<u64> {
    let metadata = std::fs::metadata(path)?;
    let kind = metadata.file_type();
    if kind.is_dir() {
        return Err(invalid("it is a directory, not a file"));
    }
    if !kind.is_file() {
        return Err(invalid(
            "it is not a regular file (a device, FIFO or socket), which may never end",
        ));
    }
    if metadata.len() > MAX_INPUT_BYTES {
        return Err(invalid(&format!(
            "it is {} bytes, more than the {MAX_INPUT_BYTES} rift reads",
            metadata.len()
        )));
    }
    Ok(metadata.len())
}

/// The bytes of a regular file, read no further than its size said (a file that grows while
/// it is read is cut there).
pub fn read(path: &Path) -> io::Result<Vec<u8>> {
    let size = regular_file(path)?;
    let mut bytes = Vec::with_capacity(size as usize);
    std::fs::File::open(path)?
        .take(size)
        .read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// [`read`] as UTF-8 text.
pub fn read_to_string(path: &Path) -> io::Result<String> {
    String::from_utf8(read(path)?).map_err(|_| invalid("it is not UTF-8 text"))
}

fn invalid(message: &str) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directories_devices_and_fifos_are_refused_and_files_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let err = read(dir.path()).unwrap_err().to_string();
        assert!(err.contains("directory"), "{err}");
        #[cfg(unix)]
        {
            let err = read(Path::new("/dev/zero")).unwrap_err().to_string();
            assert!(err.contains("not a regular file"), "{err}");
            let fifo = dir.path().join("fifo");
            let made = std::process::Command::new("mkfifo").arg(&fifo).status();
            if made.is_ok_and(|s| s.success()) {
                let err = read(&fifo).unwrap_err().to_string();
                assert!(err.contains("not a regular file"), "{err}");
            }
        }
        let file = dir.path().join("a.txt");
        std::fs::write(&file, "héllo").unwrap();
        assert_eq!(read_to_string(&file).unwrap(), "héllo");
        std::fs::write(&file, [0xff, 0xfe]).unwrap();
        assert!(
            read_to_string(&file)
                .unwrap_err()
                .to_string()
                .contains("UTF-8")
        );
        assert!(read(&dir.path().join("missing")).is_err());
    }
}
