
(function(){
var box=document.currentScript.parentNode;
var d=JSON.parse(box.querySelector('.hit-data').textContent);
var W=440,H=150,HC=60,L=50;
var pts=Array.from(box.querySelectorAll('[data-hit-choice-point]'));
function on(el){return Array.from(el.querySelectorAll('input.hit-pick'))
 .map(function(c){return c.checked;});}
function xs(f){var a=d.freq[0],b=d.freq[d.freq.length-1];return L+(W-L-10)*(f-a)/(b-a);}
function line(v,lo,hi,top,h,col,wd){var p=[];
 for(var k=0;k<v.length;k++){if(!isFinite(v[k]))continue;
  var y=top+h-h*(Math.min(Math.max(v[k],lo),hi)-lo)/(hi-lo);
  p.push(xs(d.freq[k]).toFixed(1)+','+y.toFixed(1));}
 return '<polyline fill="none" stroke="'+col+'" stroke-width="'+wd+'" points="'
  +p.join(' ')+'"/>';}
function draw(j){var el=pts[j],pt=d.points[j],c=on(el),n=d.freq.length,m=0,hits=[];
 var sf=new Array(n).fill(0),sr=new Array(n).fill(0),si=new Array(n).fill(0);
 var sx=new Array(n).fill(0);
 pt.hits.forEach(function(h,i){if(!c[i]||!h.sff)return;m++;var db=[];
  for(var k=0;k<n;k++){sf[k]+=h.sff[k];sr[k]+=h.sfr[k];si[k]+=h.sfi[k];sx[k]+=h.sxx[k];
   var a=h.sfr[k]*h.sfr[k]+h.sfi[k]*h.sfi[k];db.push(10*Math.log10(a/(h.sff[k]*h.sff[k])));}
  hits.push(db);});
 var avg=[],coh=[];
 for(var k=0;k<n;k++){var a=sr[k]*sr[k]+si[k]*si[k];
  avg.push(10*Math.log10(a/(sf[k]*sf[k])));coh.push(a/(sf[k]*sx[k]));}
 var all=hits.concat([avg]).flat().filter(isFinite);
 var hi=Math.max.apply(null,all),lo=Math.max(Math.min.apply(null,all),hi-80);
 var s='<svg class="fig" viewBox="0 0 '+W+' '+(H+HC+40)+'" width="'+W+'">';
 s+='<text x="4" y="'+(H+10)+'" font-size="10">'+lo.toFixed(0)+'</text>';
 s+='<text x="4" y="32" font-size="10">'+hi.toFixed(0)+'</text>';
 hits.forEach(function(v){s+=line(v,lo,hi,10,H,'#bbb',1);});
 if(m){s+=line(avg,lo,hi,10,H,'#000',2);s+=line(coh,0,1,H+30,HC,'#1f77b4',1.5);}
 s+='<text x="4" y="20" font-size="11">|H| dB</text>';
 s+='<text x="4" y="'+(H+40)+'" font-size="11">coh.</text>';
 s+='<text x="'+L+'" y="'+(H+HC+38)+'" font-size="11">'+d.freq[0].toFixed(0)+' Hz</text>';
 s+='<text x="'+(W-60)+'" y="'+(H+HC+38)+'" font-size="11">'+d.freq[n-1].toFixed(0)
  +' Hz</text></svg>';
 el.querySelector('.hit-plot').innerHTML=s;
 el.querySelector('.hit-count').textContent=m+' of '+pt.hits.length+' hits averaged.';}
function toml(){
 var t='# ema-pipeline hit choice: ema-pipeline frf ... --hits hits.toml\n';
 pts.forEach(function(el,j){var c=on(el),pt=d.points[j],acc=[];
  pt.hits.forEach(function(h,i){if(c[i]&&h.sff)acc.push(h.number);});
  t+='\n[[recording]]\nfile = '+JSON.stringify(pt.file)+'\naccepted = ['+acc.join(', ')+']\n';});
 box.querySelector('.hit-toml').textContent=t;}
pts.forEach(function(el,j){el.addEventListener('change',function(){draw(j);toml();});
 draw(j);});
toml();
box.querySelector('.hit-download').addEventListener('click',function(){
 var b=new Blob([box.querySelector('.hit-toml').textContent],{type:'text/plain'});
 var a=document.createElement('a');a.href=URL.createObjectURL(b);
 a.download='hits.toml';document.body.appendChild(a);a.click();a.remove();});
})();
