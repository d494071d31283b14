//! The replay's `trace.csv`: one line per sample in the user's units, formatted into memory by the
//! sample loop and written by a thread of its own, so that the paced loop never makes a system
//! call (a write stalling for a few hundred µs would be an overrun at Ts = 0.455 ms).

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::Sender;
use std::thread::JoinHandle;

use sledid::ident::step::StepOutput;

use crate::recording::Sample;

/// Bytes formatted before a chunk goes to the writer thread.
const CHUNK: usize = 1 << 16;

/// The trace being written.
pub(super) struct TraceWriter {
    /// The file, for errors.
    path: PathBuf,
    /// Full chunks to the writer thread.
    chunks: Sender<Vec<u8>>,
    /// The writer thread.
    writer: JoinHandle<std::io::Result<()>>,
    /// The chunk being formatted.
    chunk: Vec<u8>,
    /// From the normalised units the estimator runs in to the user's: y, u, each θ.
    y_factor: f64,
    u_factor: f64,
    theta_factors: Vec<f64>,
}

impl TraceWriter {
    /// Creates `out/trace.csv` with its header (θ columns as many as `theta_factors`), the
    /// writer thread started; lines are mapped back to the user's units by the factors.
    ///
    /// # Errors
    /// The file cannot be created (named).
    pub(super) fn create(
        out: &Path,
        (y_factor, u_factor): (f64, f64),
        theta_factors: Vec<f64>,
    ) -> Result<Self, String> {
        let path = out.join("trace.csv");
        let file = std::fs::File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let (chunks, received) = std::sync::mpsc::channel::<Vec<u8>>();
        let writer = std::thread::spawn(move || -> std::io::Result<()> {
            let mut w = BufWriter::new(file);
            for chunk in received {
                w.write_all(&chunk)?;
            }
            w.flush()
        });
        let mut chunk: Vec<u8> = Vec::with_capacity(CHUNK);
        let theta_cols: Vec<String> = (0..theta_factors.len())
            .map(|i| format!("theta{i}"))
            .collect();
        writeln!(
            chunk,
            "t_s,u,y,y_c,u_c,y_hat,eps,{},flags",
            theta_cols.join(",")
        )
        .map_err(|e| e.to_string())?;
        Ok(Self {
            path,
            chunks,
            writer,
            chunk,
            y_factor,
            u_factor,
            theta_factors,
        })
    }

    /// The line of one sample: the recorded `s` and the step's output `o`.
    ///
    /// # Errors
    /// The writer thread has stopped.
    pub(super) fn line<const N: usize>(
        &mut self,
        s: &Sample,
        o: &StepOutput<N>,
    ) -> Result<(), String> {
        let (ky, ku) = (self.y_factor, self.u_factor);
        let th: Vec<String> = o
            .theta
            .iter()
            .zip(&self.theta_factors)
            .map(|(p, k)| (p.to_f64() * k).to_string())
            .collect();
        writeln!(
            self.chunk,
            "{},{},{},{},{},{},{},{},{}",
            s.t_s,
            s.u,
            s.y,
            o.y.to_f64() * ky,
            o.u.to_f64() * ku,
            o.y_hat.to_f64() * ky,
            o.eps.to_f64() * ky,
            th.join(","),
            o.status.bits()
        )
        .map_err(|e| e.to_string())?;
        if self.chunk.len() >= CHUNK {
            let full = std::mem::replace(&mut self.chunk, Vec::with_capacity(CHUNK));
            self.chunks
                .send(full)
                .map_err(|_| "trace writer stopped".to_owned())?;
        }
        Ok(())
    }

    /// Sends the last chunk and waits for the file to be written.
    ///
    /// # Errors
    /// The writer thread stopped, panicked or failed to write (the file named).
    pub(super) fn finish(self) -> Result<(), String> {
        self.chunks
            .send(self.chunk)
            .map_err(|_| "trace writer stopped".to_owned())?;
        drop(self.chunks);
        self.writer
            .join()
            .map_err(|_| "trace writer panicked".to_owned())?
            .map_err(|e| format!("{}: {e}", self.path.display()))
    }
}
