// The patent's numbers of JP H01-193709 A Example 1 (the library's JP 1989-193709) as LensVisualizer
// transcribes them (src/lens-data/minolta/Minolta2885mmf3545MDZoom.data.ts, commit 95431a2e9a56):
// radii, gaps, the zoom states' focal lengths and variable gaps at infinity focus. Rows only (no
// glass). Its nominalFno is a fixed-stop model's; the patent's printed F-numbers 3.6 / 4.0 / 4.63 are
// those its comment quotes (merge_zoom_states.py, F_NUMBER_OVERRIDES).
const LENS_DATA = {
  surfaces: [
    { label: "1", R: 333.333, d: 1.7, nd: 1.7725, elemId: 1 },
    { label: "2", R: 37.379, d: 6, nd: 1.0, elemId: 0 },
    { label: "3", R: 374.702, d: 5, nd: 1.80741, elemId: 2 },
    { label: "4", R: -68.96, d: 0.12, nd: 1.0, elemId: 0 },
    { label: "5", R: -175.441, d: 1.6, nd: 1.7725, elemId: 3 },
    { label: "6", R: 35.419, d: 1.8, nd: 1.0, elemId: 0 },
    { label: "7", R: 30.978, d: 2.7, nd: 1.84666, elemId: 4 },
    { label: "8", R: 42.047, d: 41.48, nd: 1.0, elemId: 0 },
    { label: "9", R: 36.673, d: 1.1, nd: 1.834, elemId: 5 },
    { label: "10", R: 18.006, d: 7.8, nd: 1.6968, elemId: 6 },
    { label: "11", R: -35.528, d: 1.1, nd: 1.75, elemId: 7 },
    { label: "12", R: -104.959, d: 0.12, nd: 1.0, elemId: 0 },
    { label: "13", R: 31.099, d: 2.6, nd: 1.618, elemId: 8 },
    { label: "14", R: 88.117, d: 1.97, nd: 1.0, elemId: 0 },
    { label: "STO", R: 1e15, d: 2.23, nd: 1.0, elemId: 0 },
    { label: "15", R: -102.718, d: 2.2, nd: 1.80518, elemId: 9 },
    { label: "16", R: -26.126, d: 1, nd: 1.7425, elemId: 10 },
    { label: "17", R: 37.626, d: 18.85, nd: 1.0, elemId: 0 },
    { label: "18", R: 116.519, d: 5, nd: 1.6405, elemId: 11 },
    { label: "19", R: -31.574, d: 0.12, nd: 1.0, elemId: 0 },
    { label: "20", R: 134.73, d: 3.2, nd: 1.67, elemId: 12 },
    { label: "21", R: -64.837, d: 2, nd: 1.0, elemId: 0 },
    { label: "22", R: -27.714, d: 1.4, nd: 1.7569, elemId: 13 },
    { label: "23", R: -831.721, d: 38.7672, nd: 1.0, elemId: 0 },
  ],
  var: {
    "8": [[41.48], [14.19], [0.8]],
    "14": [[1.97], [9.34], [19.32]],
    "17": [[18.85], [11.49], [1.5]],
    "23": [[38.7672], [46.1323], [56.1263]],
  },
  zoomPositions: [28.8, 50, 82.5],
  nominalFno: [3.637, 3.967, 4.63],
};
