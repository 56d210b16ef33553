//! [`ServiceClient`]: a minimal raw ROS 2 service client (the Mech-Eye capture service).
//!
//! A ROS 2 service on DDS is two topics, `rq/<service>Request` (type
//! `pkg::srv::dds_::Name_Request_`) and `rr/<service>Reply` (`Name_Response_`), reliable,
//! volatile, keep last 10 (`rmw_qos_profile_services_default`). How a reply finds its request
//! depends on the server's middleware ([`ServiceMapping`]):
//!
//! - [`ServiceMapping::Cyclone`] (rmw_cyclonedds): request and reply payloads start with the
//!   16-byte header `{ uint64 client_id; int64 sequence }` (little-endian, right after the
//!   encapsulation header); the server copies it into the reply. CDR alignment of the fields
//!   after it is unchanged (16 is a multiple of 8).
//! - [`ServiceMapping::FastDds`] (rmw_fastrtps, ROS 2's default middleware): no header; the
//!   reply carries the request's RTPS sample identity (writer GUID + sequence number) as its
//!   `related_sample_identity` inline QoS.
//!
//! Requests and responses are CDR with the encapsulation header, without the mapping's header
//! (`msgs`-style bytes in and out).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use rustdds::bytes::Bytes;
use rustdds::mio1::{Events, Interest, Poll};
use rustdds::no_key::{DataReader, DataWriter};
use rustdds::{RTPSEntity, SampleIdentity, WriteOptionsBuilder};

use crate::error::Ros2Error;
use crate::graph::LocalEndpoints;
use crate::raw::{RawCdr, with_header};
use crate::subscription::READER_TOKEN;

/// Length of rmw_cyclonedds' request/reply header.
pub const CYCLONE_HEADER_LEN: usize = 16;

/// How replies are matched to requests (the server's ROS 2 middleware).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServiceMapping {
    /// rmw_cyclonedds: a `{client_id, sequence}` header in the payload.
    Cyclone,
    /// rmw_fastrtps (ROS 2's default): the RTPS sample identity, echoed as the reply's
    /// related sample identity. Not yet tested against a Fast DDS server.
    FastDds,
}

/// A reply's payload and the request identity it says it answers (Fast DDS mapping).
type Reply = (Vec<u8>, Option<SampleIdentity>);

/// A raw client of one service.
pub struct ServiceClient {
    pub(crate) service: String,
    pub(crate) mapping: ServiceMapping,
    pub(crate) writer: DataWriter<Bytes, RawCdr>,
    pub(crate) reader: DataReader<Vec<u8>, RawCdr>,
    pub(crate) poll: Poll,
    pub(crate) events: Events,
    pub(crate) client_id: u64,
    pub(crate) next_sequence: i64,
    pub(crate) local: LocalEndpoints,
    pub(crate) guids: [[u8; 16]; 2],
    /// Requests sent and not answered yet: sequence -> (Cyclone header, RTPS identity).
    pub(crate) pending: BTreeMap<i64, ([u8; CYCLONE_HEADER_LEN], SampleIdentity)>,
    /// Replies taken by [`ServiceClient::call_raw`] that answer other requests.
    pub(crate) early: Vec<(i64, Vec<u8>)>,
}

impl std::fmt::Debug for ServiceClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServiceClient")
            .field("service", &self.service)
            .field("mapping", &self.mapping)
            .finish()
    }
}

impl ServiceClient {
    pub(crate) fn new(
        service: String,
        mapping: ServiceMapping,
        writer: DataWriter<Bytes, RawCdr>,
        mut reader: DataReader<Vec<u8>, RawCdr>,
        local: LocalEndpoints,
    ) -> Result<ServiceClient, Ros2Error> {
        let poll_err = |source| Ros2Error::Poll {
            topic: service.clone(),
            source,
        };
        let poll = Poll::new().map_err(poll_err)?;
        poll.registry()
            .register(&mut reader, READER_TOKEN, Interest::READABLE)
            .map_err(poll_err)?;
        let writer_guid = writer.guid().to_bytes();
        let mut id = [0_u8; 8];
        id.copy_from_slice(&writer_guid[8..]);
        let guids = [writer_guid, reader.guid().to_bytes()];
        Ok(ServiceClient {
            service,
            mapping,
            writer,
            reader,
            poll,
            events: Events::with_capacity(4),
            // The last 8 GUID bytes (participant-unique part + entity id), as rmw_cyclonedds.
            client_id: u64::from_le_bytes(id),
            next_sequence: 1,
            local,
            guids,
            pending: BTreeMap::new(),
            early: Vec::new(),
        })
    }

    /// The service name.
    pub fn service(&self) -> &str {
        &self.service
    }

    /// Sends `request` (CDR with encapsulation header) and waits up to `timeout` for its
    /// response; `None` when none came in time. Replies to other pending requests that arrive
    /// meanwhile stay pending ([`ServiceClient::try_reply`] finds them).
    ///
    /// # Errors
    /// [`Ros2Error::PayloadTooShort`], [`Ros2Error::UnsupportedEncapsulation`],
    /// [`Ros2Error::Write`], [`Ros2Error::Read`], [`Ros2Error::Poll`],
    /// [`Ros2Error::ServiceReply`] (a reply too short for the mapping's header).
    pub fn call_raw(
        &mut self,
        request: &[u8],
        timeout: Duration,
    ) -> Result<Option<Vec<u8>>, Ros2Error> {
        let sequence = self.send(request)?;
        let deadline = Instant::now() + timeout;
        let mut early: Vec<(i64, Vec<u8>)> = Vec::new();
        let result = loop {
            if let Some((seq, response)) = self.try_reply()? {
                if seq == sequence {
                    break Some(response);
                }
                early.push((seq, response));
                continue;
            }
            let now = Instant::now();
            if now >= deadline {
                self.pending.remove(&sequence);
                break None;
            }
            self.wait((deadline - now).min(Duration::from_millis(50)))?;
        };
        self.early.extend(early);
        Ok(result)
    }

    /// Sends `request` (CDR with encapsulation header) without waiting; returns its sequence
    /// number, which [`ServiceClient::try_reply`] returns with its response.
    ///
    /// # Errors
    /// [`Ros2Error::PayloadTooShort`], [`Ros2Error::UnsupportedEncapsulation`],
    /// [`Ros2Error::Write`].
    pub fn send(&mut self, request: &[u8]) -> Result<i64, Ros2Error> {
        let Some(&[b0, b1, _, _]) = request.get(..msgs::cdr::HEADER_LEN) else {
            return Err(Ros2Error::PayloadTooShort {
                topic: self.service.clone(),
                len: request.len(),
            });
        };
        if [b0, b1] != [0x00, 0x01] {
            return Err(Ros2Error::UnsupportedEncapsulation {
                topic: self.service.clone(),
                b0,
                b1,
            });
        }
        let sequence = self.next_sequence;
        self.next_sequence += 1;
        let header = self.cyclone_header(sequence);
        let payload = match self.mapping {
            ServiceMapping::Cyclone => {
                let mut p = Vec::with_capacity(request.len() + CYCLONE_HEADER_LEN);
                p.extend_from_slice(&request[..msgs::cdr::HEADER_LEN]);
                p.extend_from_slice(&header);
                p.extend_from_slice(&request[msgs::cdr::HEADER_LEN..]);
                p
            }
            ServiceMapping::FastDds => request.to_vec(),
        };
        let identity = self
            .writer
            .write_with_options(Bytes::from(payload), WriteOptionsBuilder::new().build())
            .map_err(|e| Ros2Error::Write {
                topic: self.service.clone(),
                reason: e.to_string(),
            })?;
        self.pending.insert(sequence, (header, identity));
        Ok(sequence)
    }

    /// The next response to a pending request of this client, `(sequence, response)`,
    /// without blocking; `None` when none is waiting. Replies to other clients are skipped.
    ///
    /// # Errors
    /// [`Ros2Error::Read`], [`Ros2Error::ServiceReply`].
    pub fn try_reply(&mut self) -> Result<Option<(i64, Vec<u8>)>, Ros2Error> {
        if let Some(r) = self.early.pop() {
            return Ok(Some(r));
        }
        while let Some((payload, related)) = self.take_reply()? {
            let mut found = None;
            for (&seq, (header, identity)) in &self.pending {
                if let Some(response) = self.match_reply(&payload, related, header, *identity)? {
                    found = Some((seq, response));
                    break;
                }
            }
            if let Some((seq, response)) = found {
                self.pending.remove(&seq);
                return Ok(Some((seq, response)));
            }
        }
        Ok(None)
    }

    /// Requests sent and not answered yet.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Waits up to `timeout` for a reply to arrive (no reply is taken).
    ///
    /// # Errors
    /// [`Ros2Error::Poll`].
    pub fn wait(&mut self, timeout: Duration) -> Result<(), Ros2Error> {
        match self.poll.poll(&mut self.events, Some(timeout)) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => Ok(()),
            Err(source) => Err(Ros2Error::Poll {
                topic: self.service.clone(),
                source,
            }),
        }
    }

    fn cyclone_header(&self, sequence: i64) -> [u8; CYCLONE_HEADER_LEN] {
        let mut h = [0_u8; CYCLONE_HEADER_LEN];
        h[..8].copy_from_slice(&self.client_id.to_le_bytes());
        h[8..].copy_from_slice(&sequence.to_le_bytes());
        h
    }

    fn take_reply(&mut self) -> Result<Option<Reply>, Ros2Error> {
        let sample = self
            .reader
            .take_next_sample()
            .map_err(|e| Ros2Error::Read {
                topic: self.service.clone(),
                reason: e.to_string(),
            })?;
        Ok(sample.map(|s| {
            let related = s.sample_info().related_sample_identity();
            (s.into_value(), related)
        }))
    }

    /// The response in `reply` if it answers this request (`None`: someone else's reply).
    fn match_reply(
        &self,
        reply: &[u8],
        related: Option<SampleIdentity>,
        header: &[u8; CYCLONE_HEADER_LEN],
        identity: SampleIdentity,
    ) -> Result<Option<Vec<u8>>, Ros2Error> {
        match self.mapping {
            ServiceMapping::Cyclone => {
                let h = msgs::cdr::HEADER_LEN;
                let (Some(kind), Some(got), Some(rest)) = (
                    reply.get(..2),
                    reply.get(h..h + CYCLONE_HEADER_LEN),
                    reply.get(h + CYCLONE_HEADER_LEN..),
                ) else {
                    return Err(Ros2Error::ServiceReply {
                        service: self.service.clone(),
                        len: reply.len(),
                    });
                };
                Ok((got == header).then(|| with_header([kind[0], kind[1]], rest)))
            }
            ServiceMapping::FastDds => Ok((related == Some(identity)).then(|| reply.to_vec())),
        }
    }
}

impl Drop for ServiceClient {
    fn drop(&mut self) {
        for g in &self.guids {
            self.local.remove(g);
        }
    }
}
