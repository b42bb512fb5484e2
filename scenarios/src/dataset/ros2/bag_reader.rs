//! A ROS 2 bag in MCAP, read: every message of every topic (in log-time order, file order at
//! equal times), each topic's type from its schema, and the attachments. Messages stay as the
//! file's bytes (borrowed when their chunk is uncompressed) until a caller decodes one as the
//! type it expects; compressed chunks (zstd, lz4) are refused with a message saying so, as are
//! topics whose encoding is not CDR when they are decoded.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::cdr;
use super::messages::RosMessage;

/// A bag's bytes, read at the door ([`sim::input_file`]).
pub struct BagFile {
    path: PathBuf,
    bytes: Vec<u8>,
}

/// One topic of a bag.
#[derive(Debug)]
pub struct Topic<'a> {
    /// Its name.
    pub name: String,
    /// Its message type as the schema names it (`sensor_msgs/msg/Imu`).
    pub type_name: String,
    /// Its message encoding (`cdr`).
    pub encoding: String,
    /// `(log time ns, data)` in log-time order.
    pub messages: Vec<(u64, Cow<'a, [u8]>)>,
}

/// A bag's contents.
#[derive(Debug)]
pub struct BagContents<'a> {
    /// The file (for error messages).
    pub path: &'a Path,
    /// Topics by name.
    pub topics: BTreeMap<String, Topic<'a>>,
    /// Attachments: `(name, bytes)`.
    pub attachments: Vec<(String, Cow<'a, [u8]>)>,
}

/// `pkg/msg/Name` and `pkg/Name` name the same type.
fn same_type(schema_name: &str, full: &str) -> bool {
    schema_name == full || schema_name == full.replacen("/msg/", "/", 1)
}

impl BagFile {
    /// Reads `path` (a regular file of at most 4 GiB).
    pub fn open(path: &Path) -> Result<Self, String> {
        let bytes = sim::input_file::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(Self {
            path: path.to_path_buf(),
            bytes,
        })
    }

    /// Every topic, message and attachment of the bag.
    pub fn contents(&self) -> Result<BagContents<'_>, String> {
        let err = |e: &dyn std::fmt::Display| {
            format!("{}: not a readable MCAP file: {e}", self.path.display())
        };
        // The checks a checking reader makes, before anything is read as good.
        super::bag_checksums::check(&self.bytes).map_err(|e| err(&e))?;
        let mut topics: BTreeMap<String, Topic<'_>> = BTreeMap::new();
        let stream = mcap::MessageStream::new(&self.bytes).map_err(|e| err(&e))?;
        for m in stream {
            let m = m.map_err(|e| err(&e))?;
            let topic = topics
                .entry(m.channel.topic.clone())
                .or_insert_with(|| Topic {
                    name: m.channel.topic.clone(),
                    type_name: m
                        .channel
                        .schema
                        .as_ref()
                        .map_or(String::new(), |s| s.name.clone()),
                    encoding: m.channel.message_encoding.clone(),
                    messages: Vec::new(),
                });
            topic.messages.push((m.log_time, m.data));
        }
        for t in topics.values_mut() {
            // Stable: file order at equal log times.
            t.messages.sort_by_key(|(time, _)| *time);
        }
        let mut attachments = Vec::new();
        if let Some(summary) = mcap::Summary::read(&self.bytes).map_err(|e| err(&e))? {
            for index in &summary.attachment_indexes {
                let a = mcap::read::attachment(&self.bytes, index).map_err(|e| err(&e))?;
                attachments.push((a.name, a.data));
            }
        }
        Ok(BagContents {
            path: &self.path,
            topics,
            attachments,
        })
    }
}

impl<'a> BagContents<'a> {
    /// `name`'s topic, which must carry `T`; an error naming the bag, the topic and the topics
    /// it has otherwise.
    pub fn topic<T: RosMessage>(&self, name: &str) -> Result<&Topic<'a>, String> {
        let t = self.topics.get(name).ok_or_else(|| {
            let have: Vec<String> = self
                .topics
                .values()
                .map(|t| format!("{} ({})", t.name, t.type_name))
                .collect();
            format!(
                "{}: no topic {name}; the bag has {}",
                self.path.display(),
                if have.is_empty() {
                    "no messages".into()
                } else {
                    have.join(", ")
                }
            )
        })?;
        if !same_type(&t.type_name, T::TYPE) {
            return Err(format!(
                "{}: topic {name} carries {}, expected {}",
                self.path.display(),
                t.type_name,
                T::TYPE
            ));
        }
        if t.encoding != "cdr" {
            return Err(format!(
                "{}: topic {name} is encoded as `{}`; only ROS 2's `cdr` is read",
                self.path.display(),
                t.encoding
            ));
        }
        Ok(t)
    }

    /// Every message of `name` decoded as `T`, with its log time; an error names the bag,
    /// topic and message.
    pub fn decode_all<T: RosMessage>(&self, name: &str) -> Result<Vec<(u64, T)>, String> {
        let t = self.topic::<T>(name)?;
        t.messages
            .iter()
            .enumerate()
            .map(|(i, (time, data))| Ok((*time, self.decode(t, i, data)?)))
            .collect()
    }

    /// Message `i` of topic `t` decoded as `T`.
    pub fn decode<T: RosMessage>(&self, t: &Topic, i: usize, data: &[u8]) -> Result<T, String> {
        cdr::decode::<T>(data).map_err(|e| {
            format!(
                "{}: topic {} message {} of {}: {e}",
                self.path.display(),
                t.name,
                i + 1,
                t.messages.len()
            )
        })
    }

    /// The attachment named `name`, if any.
    pub fn attachment(&self, name: &str) -> Option<&[u8]> {
        self.attachments
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, d)| d.as_ref())
    }
}
