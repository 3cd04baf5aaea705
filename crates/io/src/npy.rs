//! NPY arrays (NumPy's `.npy`): radiance, its standard error, samples per
//! pixel, layer stacks — any element type and dimension.

/// `a` as a `.npy` file's bytes, appended to `out`.
pub fn write_npy<A, S, D>(
    out: &mut Vec<u8>,
    a: &ndarray::ArrayBase<S, D>,
) -> Result<(), ndarray_npy::WriteNpyError>
where
    A: ndarray_npy::WritableElement,
    S: ndarray::Data<Elem = A>,
    D: ndarray::Dimension,
{
    use ndarray_npy::WriteNpyExt;
    let mut w = std::io::BufWriter::new(out);
    a.write_npy(&mut w)?;
    // Flush here: a BufWriter dropped with unwritten data loses the error.
    std::io::Write::flush(&mut w)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_array_is_written_with_its_header_and_values() {
        let a = ndarray::Array2::<u32>::from_shape_vec((2, 3), (0..6).collect()).unwrap();
        let mut bytes = Vec::new();
        super::write_npy(&mut bytes, &a).unwrap();
        assert!(bytes.starts_with(b"\x93NUMPY"));
        assert!(
            String::from_utf8_lossy(&bytes).contains("'shape': (2, 3)"),
            "{bytes:?}"
        );
        let tail: Vec<u32> = bytes[bytes.len() - 24..]
            .chunks(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        assert_eq!(tail, [0, 1, 2, 3, 4, 5]);
    }
}
